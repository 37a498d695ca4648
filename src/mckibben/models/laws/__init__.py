"""Every muscle force law, one file each, and the one registry of them by name.

A *law* is a pulling force F(P, l) of gauge pressure and length with a parameter vector θ. Each
lives in its own file here (``laws/<law>.py``): its compiled kernel
``kernel(pressure, length, th, o, w) -> force`` (parameter r at ``th[o + r·w]``, the plant's batch
layout), its NumPy face, its parameter dataclass and θ, and its fit spec (names, physical bounds,
initial guess, which muscle fields it needs) with the one conversion of fitted values into the
parameter object (``from_values``). Each file defines ``LAW`` (:class:`Law`).

This module is the only vocabulary: :data:`LAWS` by name, in a fixed order (the plant compiles one
branch per index, :data:`LAW_INDEX`); :func:`resolve` reads old names (``"empirical"``, ``"mpam"``
→ ``braid-map``; ``"wall-chou-hannaford"`` → ``wall-corrected``) with a deprecation warning.
Predict, fit, compare, the plant, the tool, muscle files and the CLI read it.

**Adding a law is adding its file** ``laws/<stem>.py`` (and its test), nothing else: every module of
this package not starting with ``_`` is imported and its ``LAW`` registered after the five laws the
plant was first compiled with, in file-name order, and every consumer (predict, fit, compare, the
plant, the tool, muscle files, ``params``, the MuJoCo bridge, the FMU) and the conformance suite
(``tests/test_law_conformance.py``) read it from :data:`LAWS`. A law file defines:

1. **The kernel**: a module-level function ``<name>(pressure, length, th, o, w) -> force`` [Pa, m ->
   N], parameter r at ``th[o + r·w]`` (at most :data:`NTH` rows), marked
   ``@kernel(error_model="numpy", inline="always")`` (:mod:`mckibben._kernels`); the file ends with
   ``register(__name__)``. Its θ rows are module constants (``XX_A, XX_B = range(2)``).
2. **The parameters**: a frozen dataclass with a ``citation`` field (and the fitted range, if fitted)
   whose θ the law reads.
3. **Its C face**, for the FMU: a file ``laws/<stem>.c`` beside the ``.py`` (same stem), C99,
   defining exactly one function ``static double mk_law_<stem>(double pressure, double length, const
   double *th)`` [Pa, m -> N] with θ row r at ``th[r]``; rows by the macros ``MK_<KEY>`` of
   :attr:`Law.c_rows` (``c_rows={"XX_A": XX_A, ...}``), constants by ``MK_MPA`` (and the other
   ``MK_*`` of the FMU's ``mk_model.h``), ``<math.h>`` only. The FMU's exporter concatenates every
   registered law's C face into one generated ``mk_laws.c`` with the dispatch ``mk_law(index, …)`` by
   :data:`LAW_INDEX`; no hand list. It must equal the kernel to 1e-9 relative (the conformance suite
   compiles it with the system ``cc`` and checks). A law without a ``.c`` file runs everywhere but
   the FMU, which refuses it by name.
4. ``LAW = Law(name, kernel, citation, ...)`` (:class:`~mckibben.models.laws._base.Law`): registry
   name (lower-case, hyphens; old names in ``aliases``), ``description`` (one line for listings),
   ``params`` and ``theta_of`` (parameter object -> θ), ``c_rows``, and as the law allows:
   ``fit_spec`` + ``from_values`` + ``needs`` (fitted to an isometric table; ``family=True`` across
   rest lengths), ``branches=2`` (inflate/deflate), ``published`` (``published(muscle) -> parameter
   object``: the law's parameters for a catalogue muscle, from its geometry or a published set;
   ``predict force --model <name>`` and :func:`mckibben.models.force` use it; None: the law needs a
   fit or a muscle file), ``static_flags`` (``static_flags(params, pressure, length, force) ->
   Flag mask``: where the law itself does not hold; every law is flagged for the pressure range,
   slack and NaN without it), ``plant_theta`` (``plant_theta(columns, muscle) -> θ (NTH, N)``: the
   law's θ from a plant's own fields, so ``PlantParams(force_model="<name>")`` runs it and sweeps
   over those fields work; None: the plant needs the law's parameter object). A law's statics
   (length under a load, pressure for a length: ``predict length|pressure --model``,
   :func:`mckibben.models.length`) are its force solved by
   :func:`mckibben.models.law_statics.rising_root`; nothing to add for them (a law with a closed-form
   inverse may give it as ``length_of(theta, pressure, load) -> length``, used instead of the scan;
   a law whose pull peaks and then falls as the muscle stretches gives ``peak_length(theta) ->
   length``, where a muscle file's braid ends).

The conformance suite checks a law on its fit to the bundled commercial table when it has a fit
spec, else on ``published(get_muscle("mpam143"))``; a law with neither fails it (nothing could use
it). The table of laws in ``docs/fit.md`` is :func:`law_table_markdown` (a test holds the page to
it): regenerate it when a law comes or goes.

**The plant dispatches over any number of laws**: it has no slots. Its two law dispatchers
(``law_force`` over a block's lanes, ``law_value`` at one point) are generated from :data:`LAW_NAMES`
by :mod:`mckibben.plant.physics`, one branch per index calling each law's kernel as a true global,
written as a module into the per-user cache folder and imported from there
(:func:`mckibben._jit.generated_module`), so they compile once per machine like every kernel; a new
law file changes the package's fingerprint and the generated source, so both recompile once.

The kernels return the law's raw value (negative where the law would push); the plant adds
what is not the law's (never pushing, the tube's passive stiffness, the braid's end stops).
All take SI units (Pa, m, N); the papers' cubics take P in MPa and convert inside.
"""

from __future__ import annotations

import importlib
import pkgutil
import warnings

import numpy as np
from mckibben._kernels import register

from mckibben.errors import InputError, unknown_name
from mckibben.models.laws import braid_map as _braid_map_file
from mckibben.models.laws import chou_hannaford as _chou_hannaford_file
from mckibben.models.laws import spring as _spring_file
from mckibben.models.laws import tondu_lopez as _tondu_lopez_file
from mckibben.models.laws import wall_corrected as _wall_corrected_file
from mckibben.models.laws._base import MAP_MAX_LOADS, MPA, NTH, FitSpec, Law, OwnFit, evaluate_kernel
from mckibben.models.laws.braid_map import BM_COEF, BM_K1, BM_K2, BM_LOADS, BM_LS, BM_N, braid_map, braid_map_theta
from mckibben.models.laws.chou_hannaford import CH_B, CH_C, CH_D0, CH_T, chou_hannaford, chou_hannaford_theta
from mckibben.models.laws.spring import SP_H0, SP_H1, SP_H2, SP_HIGH, SP_LOW, SP_SPLIT, spring, spring_theta
from mckibben.models.laws.tondu_lopez import TL_A, TL_B, TL_IL0, TL_K, TL_PTH, TL_R0, tondu_lopez, tondu_lopez_theta
from mckibben.models.laws.wall_corrected import wall_corrected

__all__ = [
    "LAWS", "LAW_NAMES", "LAW_INDEX", "ALIASES", "NTH", "MAP_MAX_LOADS", "MPA", "FitSpec", "Law", "OwnFit",
    "evaluate", "fit_laws", "get_law", "own_fit_laws", "law_of", "law_table_markdown", "resolve",
    "tondu_lopez", "chou_hannaford", "wall_corrected", "braid_map", "spring",
    "tondu_lopez_theta", "chou_hannaford_theta", "braid_map_theta", "spring_theta",
    "TL_R0", "TL_A", "TL_B", "TL_K", "TL_PTH", "TL_IL0", "CH_B", "CH_C", "CH_D0", "CH_T",
    "BM_LS", "BM_K1", "BM_K2", "BM_N", "BM_LOADS", "BM_COEF", "SP_H2", "SP_H1", "SP_H0", "SP_SPLIT", "SP_LOW",
    "SP_HIGH",
]

#: The laws the plant was first compiled with, in their index order (their indices never change).
_FIRST = (_tondu_lopez_file, _chou_hannaford_file, _wall_corrected_file, _braid_map_file, _spring_file)


def _discover() -> list:
    first = {m.__name__ for m in _FIRST}
    mods = list(_FIRST)
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        qual = f"{__name__}.{info.name}"
        if info.name.startswith("_") or qual in first:
            continue
        mod = importlib.import_module(qual)
        if isinstance(getattr(mod, "LAW", None), Law):
            mods.append(mod)
    return mods


#: The registry, by name, in a fixed order (the plant compiles one branch per entry).
LAWS: dict[str, Law] = {m.LAW.name: m.LAW for m in _discover()}
LAW_NAMES = tuple(LAWS)
LAW_INDEX = {name: i for i, name in enumerate(LAW_NAMES)}
#: Old names, still read: old name -> registry name.
ALIASES: dict[str, str] = {a: law.name for law in LAWS.values() for a in law.aliases}


def resolve(name: str, what: str = "force law") -> str:
    """The registry name of a law name or old alias (an alias warns once: deprecated).

    Parameters
    ----------
    name : str
        A name of :data:`LAWS` or :data:`ALIASES`. [-]
    what : str
        What the name was given as, for the message (e.g. ``"model"``). [-]

    Raises
    ------
    InputError
        An unknown name, with the closest registered ones.
    """
    if name in LAWS:
        return name
    if name in ALIASES:
        warnings.warn(f"force law name {name!r} is deprecated; use {ALIASES[name]!r}", DeprecationWarning,
                      stacklevel=2)
        return ALIASES[name]
    raise unknown_name(what, name, LAWS)


def get_law(name: str) -> Law:
    """The :class:`Law` of a name or alias (see :func:`resolve`).

    Parameters
    ----------
    name : str
        Law name. [-]
    """
    return LAWS[resolve(name)]


def own_fit_laws() -> dict[str, Law]:
    """The laws with a fit procedure of their own on non-isometric tables (:attr:`Law.own_fit`), in registry order."""
    return {n: law for n, law in LAWS.items() if law.own_fit is not None}


def fit_laws(family: bool | None = None) -> dict[str, Law]:
    """The laws that have a fit spec (fitted to isometric data), in registry order.

    Parameters
    ----------
    family : bool, optional
        Only the family laws (True), only the per-muscle laws (False), or all (None). [-]
    """
    return {n: law for n, law in LAWS.items() if law.fit_spec is not None and (family is None or law.family == family)}


def evaluate(name: str, pressure, length, theta) -> np.ndarray:
    """A law's force at pressures and lengths (its kernel element-wise): the NumPy face.

    Parameters
    ----------
    name : str
        A name of :data:`LAWS` (or an alias).
    pressure : array_like
        Gauge pressure. [Pa]
    length : array_like
        Muscle length. [m]
    theta : array_like
        The law's parameters: ``(NTH,)`` for all elements, or ``(NTH,) + shape`` per element. [SI]

    Returns
    -------
    numpy.ndarray
        Force, broadcast over ``pressure`` and ``length`` (and θ's trailing shape). [N]
    """
    name = resolve(name)
    return evaluate_kernel(LAWS[name].kernel, name, pressure, length, theta)


def law_table_markdown() -> str:
    """The table of registered laws in ``docs/fit.md``, generated from :data:`LAWS`.

    ``tests/test_docs.py`` checks that ``docs/fit.md`` holds exactly this text, so the
    documentation lists every law the registry has, and nothing else.

    Returns
    -------
    str
        Markdown: one row per law, with its source, what it is, where it is used and its old names.
    """
    rows = ["| law | source | what it is | fitted to isometric data | published set | FMU | old names |",
            "| --- | --- | --- | --- | --- | --- | --- |"]
    for name, law in LAWS.items():
        fitted = "no" if law.fit_spec is None else ("yes, a family across rest lengths" if law.family else "yes")
        rows.append(f"| `{name}` | {law.citation} | {law.description} | {fitted} | "
                    f"{'yes' if law.published is not None else 'no'} | "
                    f"{'yes' if law.c_source() is not None else 'no'} | "
                    f"{', '.join(f'`{a}`' for a in law.aliases) or '-'} |")
    return "\n".join(rows) + "\n"


def law_of(model, law: str | None = None, direction: str = "elongation") -> tuple[str, np.ndarray]:
    """The registered law and θ of a static model object.

    The laws say which objects are theirs (:attr:`Law.params`, :attr:`Law.accepts`); nothing here
    knows the model classes.

    Parameters
    ----------
    model : object
        A parameter object of a registered law: a :class:`~mckibben.models.mpam.MiniatureMuscle`
        (its braid-angle map), :class:`~mckibben.models.laws.tondu_lopez.TonduLopez`,
        :class:`~mckibben.models.geometry.BraidGeometry` (Chou–Hannaford; wall-corrected when it
        has a wall), :class:`~mckibben.models.laws.spring.SpringModel`, or any added law's.
    law : str, optional
        The law, when several take the object (a BraidGeometry: ``"chou-hannaford"`` or
        ``"wall-corrected"``).
    direction : str, default "elongation"
        For a two-branch law (the spring model): its coefficient set. [-]

    Returns
    -------
    (str, numpy.ndarray)
        Law name and θ of shape ``(NTH,)``.
    """
    takers = [lw for lw in LAWS.values() if lw.theta_of is not None
              and (isinstance(model, lw.params) if lw.params is not None else bool(lw.accepts and lw.accepts(model)))]
    if law is not None:
        name = resolve(law)
        chosen = [lw for lw in takers if lw.name == name]
        if not chosen:
            kinds = " or ".join(lw.name for lw in takers) or "no law"
            raise InputError(f"a {type(model).__name__} drives {kinds}, not {law!r}")
    else:
        chosen = [lw for lw in takers if lw.accepts is None or lw.accepts(model)] or takers
    if not chosen:
        raise InputError(f"no force law for a {type(model).__name__}; give a parameter object of one of "
                         f"{', '.join(LAWS)}")
    return chosen[0].name, chosen[0].theta_of(model, direction)


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
