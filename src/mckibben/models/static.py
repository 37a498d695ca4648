"""One calling convention for the static models, one result type (pvlib's ``calcparams_*`` habit).

Every length model is ``length_<model>(pressure, load, muscle) -> StaticResult`` and every force
model ``force_<model>(pressure, length, muscle) -> StaticResult``; :func:`length` and
:func:`force` pick one by name (:data:`LENGTH_MODELS`; for force, any registered law with a published
parameter set, :func:`force_laws`). Inputs are arrays
(broadcast together) in SI, or single quantities as text with a unit (``"0.8MPa"``). The result
carries the inputs, the outputs, the contraction and the flags (:mod:`mckibben.models.flags`)
of every element, whatever the model.

The models themselves stay where they are written once: :mod:`~mckibben.models.mpam` (eq. 2
with eq. 3 of “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt)) and :mod:`~mckibben.models.physical` (Chou–Hannaford,
with and without the tube wall, on the muscle's construction, §II).

>>> from mckibben.datasets import get_muscle
>>> r = length(0.8e6, 0.6, get_muscle("mpam97"), model="mpam")
>>> round(float(r.length) * 1e3, 1)
78.1
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, check_array, unknown_name
from mckibben.models import laws
from mckibben.models.flags import Flag, flag_names, flag_where, outside
from mckibben.models.mpam import _check_muscle as _check_mpam_muscle
from mckibben.models.mpam import MAX_POINTS, MAX_SOLVE_POINTS, check_points
from mckibben.units import quantity
from mckibben.models.physical import miniature_geometry
from mckibben.models.mpam import predict_length
from mckibben.models.physical import length_under_load

__all__ = ["LENGTH_MODELS", "StaticResult", "force", "force_chou_hannaford", "force_laws", "force_mpam",
           "force_wall_corrected", "length", "length_chou_hannaford", "length_mpam", "length_wall_corrected"]


@dataclass(frozen=True)
class StaticResult:
    """A static model evaluated on arrays: what went in, what came out, and the flags.

    Attributes
    ----------
    model : str
        The model's name (a key of :data:`LENGTH_MODELS`, or a law's registry name). [-]
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
    """

    model: str
    pressure: np.ndarray
    load: np.ndarray
    length: np.ndarray
    contraction: np.ndarray
    flags: np.ndarray

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


def _model_name(model, kind: str, models) -> str:
    if not isinstance(model, str):
        raise ArgumentTypeError(f"model = {model!r}: not a model name ({type(model).__name__}); "
                                f"give one of: {', '.join(sorted(models))}")
    if model not in models:
        raise unknown_name(kind, model, models)
    return model


def _check_muscle(muscle) -> None:
    _check_mpam_muscle(muscle)


def _geometry(muscle, wall: bool):

    return miniature_geometry(muscle.nominal_length, muscle.geometry, wall=wall)


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
    “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt), eq. (2) with (3), Tables I and II.
    """

    _check_muscle(muscle)
    r = predict_length(muscle, *_pair(MAX_POINTS, pressure=pressure, load=load))
    return StaticResult("mpam", r.pressure, r.load, r.length, r.contraction, r.flags)


def _length_physical(pressure, load, muscle, wall: bool, name: str) -> StaticResult:

    _check_muscle(muscle)
    p, f = _pair(MAX_SOLVE_POINTS, pressure=pressure, load=load)
    ell, flags = length_under_load(p, f, _geometry(muscle, wall), "wall-corrected" if wall else "chou-hannaford")
    return StaticResult(name, p, f, ell, 1.0 - ell / muscle.nominal_length, flags)


def length_chou_hannaford(pressure, load, muscle) -> StaticResult:
    """Length under a hanging load from the thin-walled Chou–Hannaford force law.

    Parameters
    ----------
    pressure : array_like or str
        Gauge pressure. [Pa]
    load : array_like or str
        Hanging load. [N]
    muscle : MiniatureMuscle
        The muscle (its nominal length and construction, §II of “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt)). [-]

    Returns
    -------
    StaticResult
    """
    return _length_physical(pressure, load, muscle, False, "chou-hannaford")


def length_wall_corrected(pressure, load, muscle) -> StaticResult:
    """Length under a hanging load from the Chou–Hannaford law with the tube wall's thickness.

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
    return _length_physical(pressure, load, muscle, True, "wall-corrected")


def force_mpam(pressure, length, muscle) -> StaticResult:
    """Force the muscle pulls with at a pressure and length: the empirical model solved for the load.

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
    “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt), eq. (2) with (3), Tables I and II.
    """

    return dataclasses.replace(force(pressure, length, muscle, "braid-map"), model="mpam")


def _force_physical(pressure, length, muscle, wall: bool, name: str) -> StaticResult:
    return force(pressure, length, muscle, name)


def force_chou_hannaford(pressure, length, muscle) -> StaticResult:
    """Force from the thin-walled Chou–Hannaford law at a pressure and length.

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
    return _force_physical(pressure, length, muscle, False, "chou-hannaford")


def force_wall_corrected(pressure, length, muscle) -> StaticResult:
    """Force from the Chou–Hannaford law with the tube wall's thickness at a pressure and length.

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
    return _force_physical(pressure, length, muscle, True, "wall-corrected")


#: Length models by name: ``f(pressure, load, muscle) -> StaticResult``.
LENGTH_MODELS: dict[str, Callable[..., StaticResult]] = {
    "mpam": length_mpam, "chou-hannaford": length_chou_hannaford, "wall-corrected": length_wall_corrected}


def force_laws() -> dict[str, str]:
    """The registered laws :func:`force` evaluates on a catalogue muscle (those with a published set), with their descriptions."""
    return {n: law.description for n, law in laws.LAWS.items() if law.published is not None}


def length(pressure, load, muscle, model: str = "mpam") -> StaticResult:
    """Length under a hanging load from the named model (:data:`LENGTH_MODELS`).

    Parameters
    ----------
    pressure : array_like or str
        Gauge pressure. [Pa]
    load : array_like or str
        Hanging load. [N]
    muscle : MiniatureMuscle
        The muscle. [-]
    model : str, default "mpam"
        ``mpam``, ``chou-hannaford`` or ``wall-corrected``. [-]
    """
    _model_name(model, "length model", LENGTH_MODELS)
    return LENGTH_MODELS[model](pressure, load, muscle)


def force(pressure, length, muscle, model: str = "braid-map", **options) -> StaticResult:
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
    muscle : MiniatureMuscle
        The muscle. [-]
    model : str, default "braid-map"
        A law's registry name (old names such as ``mpam`` are read, with a deprecation warning). [-]
    options : keyword arguments
        Fields of the law's parameter object to replace (e.g. ``k=1.3`` for Tondu–Lopez's
        contraction correction). [SI]

    Returns
    -------
    StaticResult
        With ``model`` the law's registry name.

    References
    ----------
    Each law's own file (:mod:`mckibben.models.laws`) cites its paper and equation.
    """
    if not isinstance(model, str):
        raise ArgumentTypeError(f"model = {model!r}: not a model name ({type(model).__name__}); "
                                f"give one of: {', '.join(force_laws())}")
    name = laws.resolve(model, "force model")
    law = laws.LAWS[name]
    if law.published is None:
        raise InputError(f"model: {name} has no published parameters for a catalogue muscle (fit it to your data: "
                         f"mckibben fit ... --model {name} --save FILE.toml); these have: {', '.join(force_laws())}")
    _check_muscle(muscle)
    p, ell = _pair(MAX_SOLVE_POINTS, pressure=pressure, length=length)
    params = law.published(muscle)
    for key, value in options.items():
        if not hasattr(params, key) or not dataclasses.is_dataclass(params):
            raise InputError(f"{key}: the {name} law's parameters have no {key!r}")
        params = dataclasses.replace(params, **{key: value})
    f = np.asarray(laws.evaluate(name, p, ell, law.theta_of(params, "elongation")), dtype=float)
    flags = (outside(p, *muscle.braid_map.pressure_range, Flag.PRESSURE_OUT_OF_RANGE)
             | flag_where(f < 0.0, Flag.SLACK) | flag_where(np.isnan(f), Flag.UNREACHABLE))
    if law.static_flags is not None:
        flags = flags | law.static_flags(params, p, ell, f)
    return StaticResult(name, p, f, ell, 1.0 - ell / muscle.nominal_length, np.asarray(flags).astype(np.uint16))
