"""One calling convention for the static models, one result type (pvlib's ``calcparams_*`` habit).

:func:`force`, :func:`length` and :func:`pressure` evaluate any registered law
(:data:`mckibben.models.laws.LAWS`) with a published parameter set (:func:`force_laws`) on a
catalogue muscle, or a muscle file's fitted law (a :class:`~mckibben.models.law_statics.LawMuscle`,
for length and pressure): the force by the law's kernel, the length and the pressure by solving
that force for them (:class:`~mckibben.models.law_statics.LawMuscle`). Inputs are arrays
(broadcast together) in SI, or single quantities as text with a unit (``"0.8MPa"``). The result
carries the inputs, the outputs, the contraction and the flags (:mod:`mckibben.models.flags`)
of every element, whatever the model.

The laws themselves stay where they are written once, one file each in :mod:`mckibben.models.laws`;
:func:`length_mpam` is the braid map's closed-form inverse (eq. 2 with eq. 3 of
[mpam-characterization], :func:`~mckibben.models.mpam.predict_length`), which ``length(...,
"braid-map")`` equals to the root finder's tolerance.

>>> from mckibben.datasets import get_muscle
>>> r = length(0.8e6, 0.6, get_muscle("mpam97"), model="braid-map")
>>> round(float(r.length) * 1e3, 1)
78.1
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, check_array
from mckibben.models import laws
from mckibben.models.flags import Flag, flag_names, flag_where, outside
from mckibben.models.mpam import _check_muscle as _check_mpam_muscle
from mckibben.models.mpam import MAX_POINTS, MAX_SOLVE_POINTS, check_points
from mckibben.units import quantity
from mckibben.models.geometry import miniature_geometry
from mckibben.models.law_statics import LawMuscle
from mckibben.models.mpam import predict_length
from mckibben.models.laws.chou_hannaford import LAW as _CH_LAW
from mckibben.models.laws.wall_corrected import LAW as _WALL_LAW

#: The law :func:`force`, :func:`length` and :func:`pressure` use for a catalogue muscle when no
#: ``model`` is given: its braid-angle map (eq. 2 + 3 of [mpam-characterization]), the one default.
DEFAULT_LAW = "braid-map"

__all__ = ["StaticResult", "force", "force_chou_hannaford", "force_laws", "force_mpam", "force_wall_corrected",
           "length", "length_chou_hannaford", "length_mpam", "length_wall_corrected", "pressure"]


@dataclass(frozen=True)
class StaticResult:
    """A static model evaluated on arrays: what went in, what came out, and the flags.

    Attributes
    ----------
    model : str
        The law's registry name (``mpam`` for :func:`length_mpam`). [-]
    pressure : numpy.ndarray
        Gauge pressure. [Pa]
    load : numpy.ndarray
        Axial force: the hanging load (length models) or the force the muscle pulls with
        (force models). [N]
    length : numpy.ndarray
        Muscle length. [m]
    contraction : numpy.ndarray
        1 − length / nominal length. [-]
    flags : numpy.ndarray
        :class:`~mckibben.models.flags.Flag` mask per element. [-]
    cos_theta : numpy.ndarray or None
        cos θ = l/b of the braid the length was solved on (:func:`length`, :func:`pressure`); None
        for :func:`force`. [-]
    """

    model: str
    pressure: np.ndarray
    load: np.ndarray
    length: np.ndarray
    contraction: np.ndarray
    flags: np.ndarray
    cos_theta: np.ndarray | None = None

    def to_pandas(self):
        """One row per element: ``pressure_Pa``, ``load_N``, ``length_m``, ``contraction``, ``flags``."""
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        b = np.broadcast_arrays(self.pressure, self.load, self.length, self.contraction, self.flags)
        return pd.DataFrame({"pressure_Pa": b[0].ravel(), "load_N": b[1].ravel(), "length_m": b[2].ravel(),
                             "contraction": b[3].ravel(),
                             "flags": [", ".join(flag_names(int(f))) for f in b[4].ravel()]})

    def __repr__(self) -> str:
        n = int(np.size(self.length))
        if n == 1:
            return (f"StaticResult(model={self.model!r}, pressure={float(self.pressure):.4g} Pa, "
                    f"load={float(self.load):.4g} N, length={float(self.length):.5g} m, "
                    f"flags={flag_names(int(self.flags))})")
        return f"StaticResult(model={self.model!r}, {n} points, {int(np.count_nonzero(self.flags))} flagged)"


def _si(value, dimension: str, name: str, limit: int = MAX_POINTS):
    """The argument ``name`` as a float array: finite numbers (no None, bool, NaN), or text with a unit."""
    if isinstance(value, str):
        return quantity(value, dimension, name, allow_negative=False)
    return check_array(value, name, lo=0.0, size=limit)


def _pair(limit: int, **given) -> list[np.ndarray]:
    """Two arguments in SI (:func:`_si`), broadcast together within ``limit`` elements (:func:`check_points`)."""
    dims = {"pressure": "pressure", "load": "force", "length": "length"}
    return check_points(limit, **{name: _si(v, dims[name], name, limit) for name, v in given.items()})


def _check_muscle(muscle) -> None:
    _check_mpam_muscle(muscle)


def length_mpam(pressure, load, muscle) -> StaticResult:
    """Length under a hanging load from the braid-angle cubics and the fitted pantograph.

    Parameters
    ----------
    pressure : array_like or str
        Gauge pressure. [Pa]
    load : array_like or str
        Hanging load. [N]
    muscle : MiniatureMuscle
        A published or fitted set (``get_muscle("mpam97")``). [-]

    Returns
    -------
    StaticResult

    References
    ----------
    [mpam-characterization], eq. (2) with (3), Tables I and II.
    """

    _check_muscle(muscle)
    r = predict_length(muscle, *_pair(MAX_POINTS, pressure=pressure, load=load))
    return StaticResult("mpam", r.pressure, r.load, r.length, r.contraction, r.flags)


def length_chou_hannaford(pressure, load, muscle) -> StaticResult:
    """Length under a hanging load from the thin-walled Chou–Hannaford force law.

    .. deprecated:: 0.1.0
        A second name of one registered law: use :func:`length` with ``model="chou-hannaford"``.

    Parameters
    ----------
    pressure : array_like or str
        Gauge pressure. [Pa]
    load : array_like or str
        Hanging load. [N]
    muscle : MiniatureMuscle
        The muscle (its nominal length and construction, §II of [mpam-characterization]). [-]

    Returns
    -------
    StaticResult
    """
    warnings.warn("mckibben.models.static.length_chou_hannaford is deprecated; "
                  "use length(pressure, load, muscle, 'chou-hannaford')", DeprecationWarning, stacklevel=2)
    return length(pressure, load, muscle, _CH_LAW.name)


def length_wall_corrected(pressure, load, muscle) -> StaticResult:
    """Length under a hanging load from the Chou–Hannaford law with the tube wall's thickness.

    .. deprecated:: 0.1.0
        A second name of one registered law: use :func:`length` with ``model="wall-corrected"``.

    Parameters
    ----------
    pressure : array_like or str
        Gauge pressure. [Pa]
    load : array_like or str
        Hanging load. [N]
    muscle : MiniatureMuscle
        The muscle (its nominal length and construction). [-]

    Returns
    -------
    StaticResult
    """
    warnings.warn("mckibben.models.static.length_wall_corrected is deprecated; "
                  "use length(pressure, load, muscle, 'wall-corrected')", DeprecationWarning, stacklevel=2)
    return length(pressure, load, muscle, _WALL_LAW.name)


def force_mpam(pressure, length, muscle) -> StaticResult:
    """Force the muscle pulls with at a pressure and length: the empirical model solved for the load.

    .. deprecated:: 0.1.0
        A second name of one registered law: use :func:`force` with ``model="braid-map"`` (whose result
        says ``braid-map``, this one ``mpam``).

    Parameters
    ----------
    pressure : array_like or str
        Gauge pressure. [Pa]
    length : array_like or str
        Muscle length. [m]
    muscle : MiniatureMuscle
        A published or fitted set. [-]

    Returns
    -------
    StaticResult

    References
    ----------
    [mpam-characterization], eq. (2) with (3), Tables I and II.
    """

    warnings.warn("mckibben.models.static.force_mpam is deprecated; "
                  "use force(pressure, length, muscle, 'braid-map')", DeprecationWarning, stacklevel=2)
    return dataclasses.replace(force(pressure, length, muscle, DEFAULT_LAW), model="mpam")


def force_chou_hannaford(pressure, length, muscle) -> StaticResult:
    """Force from the thin-walled Chou–Hannaford law at a pressure and length.

    .. deprecated:: 0.1.0
        A second name of one registered law: use :func:`force` with ``model="chou-hannaford"``.

    Parameters
    ----------
    pressure : array_like or str
        Gauge pressure. [Pa]
    length : array_like or str
        Muscle length. [m]
    muscle : MiniatureMuscle
        The muscle (its nominal length and construction). [-]

    Returns
    -------
    StaticResult
    """
    warnings.warn("mckibben.models.static.force_chou_hannaford is deprecated; "
                  "use force(pressure, length, muscle, 'chou-hannaford')", DeprecationWarning, stacklevel=2)
    return force(pressure, length, muscle, _CH_LAW.name)


def force_wall_corrected(pressure, length, muscle) -> StaticResult:
    """Force from the Chou–Hannaford law with the tube wall's thickness at a pressure and length.

    .. deprecated:: 0.1.0
        A second name of one registered law: use :func:`force` with ``model="wall-corrected"``.

    Parameters
    ----------
    pressure : array_like or str
        Gauge pressure. [Pa]
    length : array_like or str
        Muscle length. [m]
    muscle : MiniatureMuscle
        The muscle (its nominal length and construction). [-]

    Returns
    -------
    StaticResult
    """
    warnings.warn("mckibben.models.static.force_wall_corrected is deprecated; "
                  "use force(pressure, length, muscle, 'wall-corrected')", DeprecationWarning, stacklevel=2)
    return force(pressure, length, muscle, _WALL_LAW.name)


def force_laws() -> dict[str, str]:
    """The registered laws :func:`force`, :func:`length` and :func:`pressure` evaluate on a catalogue muscle (those with a published set), with their descriptions."""
    return {n: law.description for n, law in laws.LAWS.items() if law.published is not None}


def _statics(muscle, model: str | None):
    """``(law name, statics, parameters)`` of a muscle by a registered law.

    The statics are an object with ``length_for_pressure(p, load)`` and ``pressure_for_length(l,
    load, p_max)``: the law's parameter object itself where it carries its own exact inverse (the
    braid map: eq. 2 with eq. 3 of [mpam-characterization] solved for the braid angle, its
    :func:`~mckibben.models.mpam.predict_length`), else a
    :class:`~mckibben.models.law_statics.LawMuscle` that solves the law's force between the end stops
    ``b/√3`` and ``b`` of the law's own straight braid or else the muscle's ideal braid (eq. 1). A
    :class:`~mckibben.models.law_statics.LawMuscle` given as the muscle (a muscle file's) is its own
    statics, with its own law (``model`` None or that law).
    """
    if model is not None and not isinstance(model, str):
        raise ArgumentTypeError(f"model = {model!r}: not a model name ({type(model).__name__}); "
                                f"give one of: {', '.join(force_laws())}")
    if isinstance(muscle, LawMuscle):
        if model is not None and laws.resolve(model, "model") != muscle.law:
            raise InputError(f"model: {model!r} is not the {muscle.law} law of muscle {muscle.name!r}; "
                             "leave it out to use the muscle's own law")
        return muscle.law, muscle, None
    name, law, params = _published(DEFAULT_LAW if model is None else model, muscle, "model")
    if hasattr(params, "length_for_pressure") and hasattr(params, "pressure_for_length"):
        return name, params, params
    b = getattr(params, "strand_length", None) or miniature_geometry(muscle.nominal_length, muscle.geometry).strand_length
    lm = LawMuscle(muscle.name, muscle.nominal_length, name, law.theta_of(params, "elongation"), float(b),
                   tuple(muscle.braid_map.pressure_range), (b / np.sqrt(3.0), b), muscle.geometry.outer_diameter,
                   citation=law.citation)
    return name, lm, params


def _published(model: str, muscle, what: str):
    """``(name, law, params)``: the registered law ``model`` (``what`` names it in errors) with its
    published parameters for the catalogue ``muscle``; refused where the law has none."""
    name = laws.resolve(model, what)
    law = laws.LAWS[name]
    if law.published is None:
        raise InputError(f"model: {name} has no published parameters for a catalogue muscle (fit it to your data "
                         f"with mckibben.fit and use the fitted muscle); these have: {', '.join(force_laws())}")
    _check_muscle(muscle)
    return name, law, law.published(muscle)


def _law_flags(name: str, params, p, ell, load, flags) -> np.ndarray:
    """The statics' flags, plus the law's own validity (:attr:`~mckibben.models.laws.Law.static_flags`)."""
    law = laws.LAWS[name]
    if law.static_flags is not None and params is not None:
        flags = flags | law.static_flags(params, p, ell, load)
    return np.asarray(flags).astype(np.uint16)


def _check_branch(branch, muscle, what: str = "length") -> None:
    """A ``branch`` is a muscle file's (a :class:`~mckibben.models.law_statics.LawMuscle` with a fitted hysteresis
    operator: a friction or a play); ``what`` names the static value for the message."""
    if branch is None:
        return
    if branch not in ("inflate", "deflate"):
        raise InputError(f"branch: {branch!r} must be inflate or deflate (or none: the static {what})")
    if not isinstance(muscle, LawMuscle) or not muscle.has_operator:
        who = f"muscle {muscle.name!r}" if isinstance(muscle, LawMuscle) else "a catalogue muscle"
        raise InputError(f"branch: {who} has no fitted friction or play (friction_area_m2 or play_threshold_Pa in "
                         "its muscle file: a bench characterization, or a direction-aware fit saved to it); leave the "
                         f"branch out for the static {what}")


def length(pressure, load, muscle, model: str | None = None, branch: str | None = None) -> StaticResult:
    """Length under a hanging load: a registered law's force solved for the length.

    The law's pull at the pressure equals the load at the returned length
    (:meth:`~mckibben.models.law_statics.LawMuscle.length_for_pressure`: the shortest such length
    between the braid's end stops; the braid map's own closed-form inverse,
    :func:`~mckibben.models.mpam.predict_length`, whose flags it keeps). Flagged: ``negative_length`` where the muscle pulls more than
    the load even at the locking angle (it rests there), ``cos_theta_above_one`` where it never
    pulls the load before the straight braid, pressures outside the characterized range, and the
    law's own validity.

    Parameters
    ----------
    pressure : array_like or str
        Gauge pressure. [Pa]
    load : array_like or str
        Hanging load. [N]
    muscle : MiniatureMuscle or LawMuscle
        A catalogue muscle, or a muscle file's (:class:`~mckibben.models.law_statics.LawMuscle`). [-]
    model : str, optional
        A law with a published parameter set (:func:`force_laws`); default ``braid-map`` (a
        catalogue muscle) or the muscle file's law. Old names (``mpam``) are read, deprecated. [-]
    branch : {"inflate", "deflate"}, optional
        A muscle file with a fitted hysteresis operator: the length on the inflating or deflating
        branch of its loop (law ∓ (F_0 + A_f·P) = load, or the law at the play's output P ∓ r = load,
        :meth:`~mckibben.models.law_statics.LawMuscle.length_for_pressure`); None: the static length. [-]

    Returns
    -------
    StaticResult
        With ``model`` the law's registry name.

    References
    ----------
    Each law's own file (:mod:`mckibben.models.laws`) cites its paper and equation.
    """
    _check_branch(branch, muscle)
    name, statics, params = _statics(muscle, model)
    p, f = _pair(MAX_SOLVE_POINTS, pressure=pressure, load=load)
    r = statics.length_for_pressure(p, f, branch) if branch is not None else statics.length_for_pressure(p, f)
    flags = _law_flags(name, params, p, r.length, f, r.flags)
    return StaticResult(name, p, f, r.length, r.contraction, flags, r.cos_theta)


def pressure(length, load, muscle, model: str | None = None, p_max: float = 0.8e6,
             branch: str | None = None) -> StaticResult:
    """The pressure that holds a length under a hanging load: a registered law's force solved for the pressure.

    :meth:`~mckibben.models.law_statics.LawMuscle.pressure_for_length`: NaN and flagged
    ``unreachable`` where no pressure in ``[0, p_max]`` holds the length (or it is past the braid's
    end stops), plus the law's own validity.

    Parameters
    ----------
    length : array_like or str
        Target length. [m]
    load : array_like or str
        Hanging load. [N]
    muscle : MiniatureMuscle or LawMuscle
        A catalogue muscle, or a muscle file's (:class:`~mckibben.models.law_statics.LawMuscle`). [-]
    model : str, optional
        As :func:`length`. [-]
    p_max : float, default 0.8e6
        Highest pressure allowed. [Pa]
    branch : {"inflate", "deflate"}, optional
        A muscle file with a fitted hysteresis operator: the pressure on the inflating or deflating
        branch of its loop (:meth:`~mckibben.models.law_statics.LawMuscle.pressure_for_length`);
        None: the static pressure. [-]

    Returns
    -------
    StaticResult
        With ``model`` the law's registry name; ``pressure`` NaN where unreachable.
    """
    _check_branch(branch, muscle, "pressure")
    name, statics, params = _statics(muscle, model)
    pmax_arr = np.asarray(_si(p_max, "pressure", "p_max"))
    if pmax_arr.size != 1:
        raise InputError(f"p_max = {p_max!r}: one pressure, not {pmax_arr.size} values")
    pmax = float(pmax_arr.reshape(()))
    if not pmax > 0:
        raise InputError(f"p_max = {p_max!r}: must be above 0 Pa")
    ell, f = _pair(MAX_SOLVE_POINTS, length=length, load=load)
    r = statics.pressure_for_length(ell, f, pmax, branch) if branch is not None else statics.pressure_for_length(ell, f, pmax)
    flags = _law_flags(name, params, np.where(np.isfinite(r.pressure), r.pressure, 0.0), ell, f, r.flags)
    return StaticResult(name, r.pressure, f, r.length, r.contraction, flags, r.cos_theta)


def force(pressure, length, muscle, model: str | None = None, branch: str | None = None, **options) -> StaticResult:
    """Force at a pressure and length from a registered law's published parameters for a catalogue muscle.

    Any law of :data:`mckibben.models.laws.LAWS` with a published parameter set
    (:attr:`~mckibben.models.laws.Law.published`, :func:`force_laws`): its parameter object for
    ``muscle``, evaluated by the law's kernel. Every law is flagged the same way: pressures
    outside the muscle's characterized range, slack (the law would push), unreachable (no value),
    and the law's own validity (:attr:`~mckibben.models.laws.Law.static_flags`: the braid's range,
    the map's characterized loads).

    Parameters
    ----------
    pressure : array_like or str
        Gauge pressure. [Pa]
    length : array_like or str
        Muscle length. [m]
    muscle : MiniatureMuscle or LawMuscle
        A catalogue muscle, or a muscle with a law of its own
        (:class:`~mckibben.models.law_statics.LawMuscle`: a muscle file's, or a law's published set,
        :func:`mckibben.datasets.law_set_muscle`). [-]
    model : str, optional
        A law's registry name (old names such as ``mpam`` are read, with a deprecation warning);
        default ``braid-map`` for a catalogue muscle, the muscle's own law for a LawMuscle. [-]
    branch : {"inflate", "deflate"}, optional
        A muscle file with a fitted hysteresis operator: the force far along the inflating or
        deflating branch of its loop (:meth:`~mckibben.models.law_statics.LawMuscle.force`); None:
        the static force. [-]
    options : keyword arguments
        Fields of the law's parameter object to replace (e.g. ``k=1.3`` for Tondu–Lopez's
        contraction correction); a catalogue muscle only. [SI]

    Returns
    -------
    StaticResult
        With ``model`` the law's registry name.

    References
    ----------
    Each law's own file (:mod:`mckibben.models.laws`) cites its paper and equation.
    """
    if model is not None and not isinstance(model, str):
        raise ArgumentTypeError(f"model = {model!r}: not a model name ({type(model).__name__}); "
                                f"give one of: {', '.join(force_laws())}")
    _check_branch(branch, muscle, "force")
    if isinstance(muscle, LawMuscle):
        return _own_force(pressure, length, muscle, model, options, branch)
    name, law, params = _published(DEFAULT_LAW if model is None else model, muscle, "force model")
    p, ell = _pair(MAX_SOLVE_POINTS, pressure=pressure, length=length)
    for key, value in options.items():
        if not hasattr(params, key) or not dataclasses.is_dataclass(params):
            raise InputError(f"{key}: the {name} law's parameters have no {key!r}")
        params = dataclasses.replace(params, **{key: value})
    f = np.asarray(laws.evaluate(name, p, ell, law.theta_of(params, "elongation")), dtype=float)
    flags = (outside(p, *muscle.braid_map.pressure_range, Flag.PRESSURE_OUT_OF_RANGE)
             | flag_where(f < 0.0, Flag.SLACK) | flag_where(np.isnan(f), Flag.UNREACHABLE))
    flags = _law_flags(name, params, p, ell, f, flags)
    return StaticResult(name, p, f, ell, 1.0 - ell / muscle.nominal_length, flags)


def _own_force(pressure, length, muscle: LawMuscle, model: str | None, options: dict,
               branch: str | None = None) -> StaticResult:
    """:func:`force` of a muscle with its own law (a muscle file's or a published set's)."""
    if model is not None and laws.resolve(model, "model") != muscle.law:
        raise InputError(f"model: {model!r} is not the {muscle.law} law of muscle {muscle.name!r}; "
                         "leave it out to use the muscle's own law")
    if options:
        raise InputError(f"{next(iter(options))}: muscle {muscle.name!r} carries its own {muscle.law} parameters; "
                         "options replace a catalogue muscle's")
    p, ell = _pair(MAX_SOLVE_POINTS, pressure=pressure, length=length)
    f = np.asarray(muscle.force(p, ell, branch), dtype=float)
    flags = (outside(p, *muscle.pressure_range, Flag.PRESSURE_OUT_OF_RANGE)
             | outside(ell, *muscle.length_range, Flag.LENGTH_OUT_OF_RANGE)
             | flag_where(f < 0.0, Flag.SLACK) | flag_where(np.isnan(f), Flag.UNREACHABLE))
    flags = _law_flags(muscle.law, getattr(muscle, "params", None), p, ell, f, flags)
    return StaticResult(muscle.law, p, f, ell, 1.0 - ell / muscle.nominal_length, flags)
