"""What every force law file shares: the θ layout, the law record and the fit spec.

A *law* is a pulling force F(P, l) of gauge pressure and length with a parameter vector θ,
written once as a Numba kernel ``kernel(pressure, length, th, o, w) -> force`` that reads its
parameter r from ``th[o + r·w]`` of a flat array: one instance's column of a ``(NTH, w)`` table
(the plant's batch layout, lanes innermost). A law file (``laws/<law>.py``) defines one
:class:`Law`; the registry (:mod:`mckibben.models.laws`) collects them.
"""

from __future__ import annotations

import sys

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mckibben import _kernels
from mckibben._kernels import PYTHON_MAX, compiled
from mckibben.errors import InputError, check_array
from mckibben.models.laws import _eval_template

#: Rows of the parameter array every law reads from (the largest law's need).
NTH = 44
#: Most characterized loads a braid-angle map may have in the kernel.
MAP_MAX_LOADS = 8
MPA = 1e6  # Pa per MPa


@dataclass(frozen=True)
class FitSpec:
    """How a law is fitted to force data F(P, L) of one muscle (or a family of muscles).

    Attributes
    ----------
    names : tuple of str
        Parameter names, with their unit in the name (``d0_m``, ``offset_N``). [-]
    lo, hi : numpy.ndarray
        Physical bounds per parameter. [SI]
    starts : list of numpy.ndarray
        Initial guesses (a multi-start for non-convex laws). [SI]
    force : callable
        ``force(values, pressure [Pa], length [m], direction=None, rest_length=None) -> [N]``: the
        law's NumPy face with the fitted values, the load cell's zero included.
    physical : callable, optional
        ``physical(values) -> list of flag names`` for non-physical results.
    priors : dict, optional
        ``{name: (median, factor)}``: a log-normal prior on a positive parameter the data may not
        see, median [parameter unit] and the factor one standard deviation spans (ln σ = ln factor)
        [-]; the fit adds it to the least squares (:func:`mckibben.fit.core.bounded_fit`) and says
        when the prior, not the data, holds the value.
    """

    names: tuple
    lo: np.ndarray
    hi: np.ndarray
    starts: list
    force: Callable
    physical: Callable | None = None
    priors: dict = field(default_factory=dict)


@dataclass(frozen=True)
class OwnFit:
    """A law's own fit procedure on tables other than isometric (beside its :class:`FitSpec`).

    The procedure itself lives in :data:`mckibben.fit.static.OWN_FITS` under the law's name (the fits
    sit above the models); this record is what the command line and the fit registry ask the law.

    Attributes
    ----------
    tables : tuple of str
        The table kinds the procedure reads (``force_length``, ``isotonic``). [-]
    note : str
        One line for the ``fit --model`` listing: what the procedure fits, on which tables. [-]
    split_pressure : bool
        Whether the procedure splits the data at a pressure (``fit --split-pressure``). [-]
    """

    tables: tuple
    note: str
    split_pressure: bool = False


@dataclass(frozen=True)
class Law:
    """One registered force law: everything the fitter, the plant, the tool and the CLI read.

    Attributes
    ----------
    name : str
        Registry name (the only vocabulary). [-]
    kernel : numba dispatcher
        ``kernel(pressure [Pa], length [m], th, o, w) -> force [N]``, parameter r at ``th[o + r·w]``.
    citation : str
        Paper and equation the law comes from.
    description : str
        One line for listings (``--model`` help). [-]
    aliases : tuple of str
        Old names still read (deprecated). [-]
    params : type, optional
        The parameter dataclass :func:`mckibben.models.laws.law_of` accepts. [-]
    theta_of : callable, optional
        ``theta_of(params, direction) -> θ (NTH,)`` of a parameter object. [SI]
    accepts : callable, optional
        ``accepts(params) -> bool``: whether an object of :attr:`params` is this law's (when two
        laws share a parameter class). [-]
    fit_spec : callable, optional
        ``fit_spec(muscle, fmax, data) -> FitSpec`` (None: not fitted to isometric data). ``muscle``
        has ``nominal_length``, ``outer_diameter`` and the optional geometry fields of a muscle
        file; ``data`` holds ``pressure``, ``held_length``, ``force``, ``direction`` (and
        ``rest_length`` for a family). [-]
    from_values : callable, optional
        ``from_values(values: dict, muscle, direction, valid_range) -> params``: the fitted values (by name, SI)
        as the law's parameter object, the load cell's zero dropped. The one conversion. [-]
    needs : tuple of str
        Muscle-file fields the fit needs. [-]
    branches : int
        1, or 2 for a law with an inflate and a deflate branch (its hysteresis). [-]
    family : bool
        Whether the law is fitted across muscles of one type (rest length is an input). [-]
    c_rows : dict
        θ rows the C face reads, ``{"XX_A": row}``: the FMU's ``mk_model.h`` defines ``MK_XX_A``. [-]
    published : callable, optional
        ``published(muscle) -> params``: the law's parameters for a catalogue muscle (its geometry
        or a published set); None when the law needs a fit or a muscle file. [-]
    static_flags : callable, optional
        ``static_flags(params, pressure [Pa], length [m], force [N]) -> Flag mask``: where the law
        itself is not valid (beyond the pressure range, slack and NaN, which every law is flagged
        for by :func:`mckibben.models.force`). [-]
    plant_theta : callable, optional
        ``plant_theta(columns, muscle) -> θ (NTH, N)``: the law's θ from a plant's own parameter
        columns (``columns``: field name -> array of the N instances, SI, e.g. ``r0``,
        ``strand_length``; ``muscle()``: the plant's catalogue muscle, for a law read from a
        published set), so ``PlantParams(force_model="<name>")`` and sweeps over those fields run the
        law without a parameter object. None: the plant needs the law's parameter object. [SI]
    length_of : callable, optional
        ``length_of(theta (NTH,), pressure [Pa], load [N]) -> length [m]``: the law's own closed-form
        inverse (its force solved for the length on its rising branch; NaN where it never pulls the
        load), which :func:`mckibben.models.law_statics.rising_root` uses instead of scanning and
        root finding. Optional: every law is solved without it. [m]
    peak_length : callable, optional
        ``peak_length(theta (NTH,)) -> length [m]``: where the law's pull peaks as the muscle is
        stretched, the same at every pressure, beyond which it falls (the wall-corrected braid); a
        muscle file's braid ends there (:class:`~mckibben.models.muscle.Muscle`), so its plant and
        FMU never run the falling branch. None: the law does not fall before the straight braid. [m]
    own_fit : OwnFit, optional
        The law's own fit procedure on non-isometric tables (the spring model's on force-length
        and isotonic tables); None: such tables are fitted through the law's force
        (:func:`mckibben.fit.isometric.fit_isotonic_law`). [-]
    extra : dict
        Law-specific facts other code may read (``optional_names``). [-]
    """

    name: str
    kernel: object
    citation: str
    description: str = ""
    aliases: tuple = ()
    params: type | None = None
    theta_of: Callable | None = None
    accepts: Callable | None = None
    fit_spec: Callable | None = None
    from_values: Callable | None = None
    needs: tuple = ()
    branches: int = 1
    family: bool = False
    extra: dict = field(default_factory=dict)
    c_rows: dict = field(default_factory=dict)
    published: Callable | None = None
    static_flags: Callable | None = None
    plant_theta: Callable | None = None
    length_of: Callable | None = None
    peak_length: Callable | None = None
    own_fit: OwnFit | None = None

    @property
    def stem(self) -> str:
        """The law file's stem (``virtual_work`` for ``laws/virtual_work.py``). [-]"""
        return self.kernel.__module__.rsplit(".", 1)[-1]

    @property
    def c_function(self) -> str:
        """The name of the C face's function, ``mk_law_<stem>``. [-]"""
        return f"mk_law_{self.stem}"

    def c_source(self) -> str | None:
        """The law's C face (``laws/<stem>.c`` beside its file), or None when it has none."""
        path = Path(sys.modules[self.kernel.__module__].__file__ or "").with_suffix(".c")
        return path.read_text() if path.is_file() else None


# --- the NumPy face of any kernel ---------------------------------------------------------------


def _eval_python(kernel, p, length, th, col, w, out):
    """The compiled loop's arithmetic, run by Python on the plain kernel (before Numba is loaded).

    NumPy scalars follow the compiled code's ``error_model="numpy"`` (no warning, inf or NaN);
    where Python's ``math`` would raise instead (a square root of a negative number), the call
    is handed to the compiled loop, which gives NaN.
    """
    try:
        with np.errstate(all="ignore"):
            for i in range(p.size):
                out[i] = kernel(p[i], length[i], th, col[i], w)
    except (ArithmeticError, ValueError):
        _eval_compiled(kernel, p, length, th, col, w, out)


def evaluate_points(kernel, pressure, length, th, col, w) -> np.ndarray:
    """A kernel at points, each with its own parameter column, compiled: the plant's layout.

    Parameters
    ----------
    kernel : function
        A law's kernel (module-level, as :attr:`Law.kernel`). [-]
    pressure, length : numpy.ndarray
        (M,) float64 gauge pressures [Pa] and lengths [m], C-contiguous.
    th : numpy.ndarray
        Flat ``(NTH, w)`` parameter table, lanes innermost (the plant's θ). [SI]
    col : numpy.ndarray
        (M,) int64 column of ``th`` each point reads. [-]
    w : int
        Columns of ``th``. [-]

    Returns
    -------
    numpy.ndarray
        (M,) force. [N]
    """
    out = np.empty(pressure.size)
    _eval_compiled(kernel, pressure, length, th, col, w, out)
    return out


def _eval_compiled(kernel, p, length, th, col, w, out):
    """The loop compiled once per law: a module generated for the kernel (``_eval_template``)."""
    jit = _kernels.jit()  # loads Numba (compiling every marked kernel)
    compiled = getattr(sys.modules[kernel.__module__], kernel.__name__)  # the dispatcher, now that Numba is loaded
    jit.module_for(_eval_template, "kernel", compiled).eval_loop(p, length, th, col, w, out)


def evaluate_kernel(kernel, name: str, pressure, length, theta) -> np.ndarray:
    """A kernel's force at pressures and lengths, element-wise: every law's NumPy face.

    Parameters
    ----------
    kernel : function
        The law's kernel (a module-level kernel of its law's file: plain Python until the package
        loads Numba, then compiled; up to ``PYTHON_MAX`` elements run as Python before that,
        with the same bits). [-]
    name : str
        The law's name, for messages. [-]
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
    th = np.asarray(theta, dtype=float)
    if th.shape[0] != NTH:
        raise InputError(f"law {name}: parameters have {th.shape[0]} rows, want {NTH}")
    p, ell = np.broadcast_arrays(check_array(pressure, "pressure", finite=False),
                                 check_array(length, "length", finite=False))
    if th.ndim > 1:
        p, ell, idx = np.broadcast_arrays(p, ell, np.arange(int(np.prod(th.shape[1:]))).reshape(th.shape[1:]))
        th2 = np.ascontiguousarray(th.reshape(NTH, -1))
    else:
        idx = np.zeros(p.shape, dtype=np.int64)
        th2 = np.ascontiguousarray(th[:, None])
    # copies, not views: a broadcast view of one element passes for contiguous, and NumPy warns
    # (FutureWarning) when a compiled call reads the writeable flag of a broadcast array
    pf = np.array(p, dtype=float, order="C").ravel()
    out = np.empty(pf.size)
    run = _eval_compiled if compiled() or pf.size > PYTHON_MAX else _eval_python
    run(kernel, pf, np.array(ell, dtype=float, order="C").ravel(), th2.ravel(),
        np.array(idx, dtype=np.int64, order="C").ravel(), th2.shape[1], out)
    return out.reshape(p.shape)


# --- what the physical laws' fits share -----------------------------------------------------------

#: Largest braid angle at rest: cos²θ = 1/3, where the ideal braid stops pulling. [rad]
THETA_MAX = float(np.arccos(1.0 / np.sqrt(3.0)))
#: Smallest braid angle at rest allowed in a fit. [rad]
THETA_MIN = float(np.deg2rad(1.0))
#: Starting braid angles of the multi-start (the physical fits are non-convex in θ0). [deg]
THETA_STARTS_DEG = (10.0, 30.0, 50.0)
#: A load cell's zero larger than this fraction of the peak force is flagged ``large_offset``: a
#: zero error of a few newtons is usual (lab-data notes), one of many percent means the model is
#: buying a constant to make up for missing physics. [-]
OFFSET_FLAG = 0.05


def offset_flag(offset: float, fmax: float) -> list:
    """``["large_offset"]`` when a fitted load-cell zero [N] exceeds :data:`OFFSET_FLAG` of the peak force [N]."""
    return ["large_offset"] if abs(offset) > OFFSET_FLAG * fmax else []


def geometry_params(muscle, what: str):
    """Outer diameter [m], nominal length [m] and the known braid angle [rad] (or None) of a muscle file.

    Parameters
    ----------
    muscle : MuscleSpec
        The muscle file. [-]
    what : str
        The law that needs them, for the message. [-]
    """
    od = muscle.need("outer_diameter", what)
    l0 = muscle.nominal_length
    theta_known = muscle.braid_angle
    if theta_known is not None and not THETA_MIN <= theta_known < THETA_MAX:
        raise InputError(f"{muscle.path or muscle.id}: key braid_angle: {np.rad2deg(theta_known):g} deg is outside"
                         f" [1, 54.7) deg, where a braid pulls")
    return od, l0, theta_known
