"""Every muscle force law once, as a compiled kernel; a registry of them by name.

A *law* is a pulling force F(P, l) of gauge pressure and length with a parameter vector θ.
Each is written here once, as a Numba kernel ``kernel(pressure, length, th, o, w) -> force``
that reads its parameter r from ``th[o + r·w]`` of a flat array: one instance's column of a
``(NTH, w)`` table (the layout the plant's batch loop keeps per block of instances, lanes
innermost, so the compiler vectorizes across them). The static
models' NumPy faces (:mod:`~mckibben.models.physical`, :mod:`~mckibben.models.mpam`,
:mod:`~mckibben.models.spring`) evaluate these same kernels through :func:`evaluate`, and the
plant (:mod:`mckibben.plant`) calls them in its integrator: one physics.

:func:`law_of` turns a static model object (published or fitted) into ``(name, θ)``, which is
how any fitted model drives the plant.

The kernels return the law's raw value (negative where the law would push); the plant adds
what is not the law's (never pushing, the tube's passive stiffness, the braid's end stops).
All take SI units (Pa, m, N); the papers' cubics take P in MPa and convert inside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mckibben._kernels import kernel, need_speed, register
from mckibben.errors import InputError

#: Rows of the parameter array every law reads from (the largest law's need).
NTH = 44
#: Most characterized loads a braid-angle map may have in the kernel.
MAP_MAX_LOADS = 8
MPA = 1e6  # Pa per MPa

# --- Tondu–Lopez with a pressure threshold -------------------------------------------------------
# θ: r0 [m], a = 3/tan²α0, b = 1/sin²α0, k [-], p_th [Pa], 1/l0 [1/m]
TL_R0, TL_A, TL_B, TL_K, TL_PTH, TL_IL0 = range(6)


@kernel(error_model="numpy", inline="always")
def tondu_lopez(pressure, length, th, o, w):
    """Tondu–Lopez force with a pressure threshold. [N]

    F = π·r0²·max(P − P_th, 0)·[a(1 − k·ε)² − b], ε = 1 − l/l0, a = 3/tan²α0, b = 1/sin²α0.
    Tondu & Lopez (2000), eq. (4); the threshold: “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt) Fig. 10.
    """
    r0 = th[o + (TL_R0) * w]
    dp = pressure - th[o + (TL_PTH) * w]
    dp = dp if dp > 0.0 else 0.0
    q = 1.0 - th[o + (TL_K) * w] * (1.0 - length * th[o + (TL_IL0) * w])
    return math.pi * r0 * r0 * dp * (th[o + (TL_A) * w] * q * q - th[o + (TL_B) * w])


# --- Chou–Hannaford --------------------------------------------------------------------------------
# θ: b strand length [m], c = π·D0²/4 [m²], D0 = b/(nπ) [m], t wall thickness [m]
CH_B, CH_C, CH_D0, CH_T = range(4)


@kernel(error_model="numpy", inline="always")
def chou_hannaford(pressure, length, th, o, w):
    """Ideal thin-walled muscle: F = (π·D0²·P/4)·(3cos²θ − 1), cos θ = l/b. [N]

    Chou & Hannaford (1996), eq. (6).
    """
    c = length / th[o + (CH_B) * w]
    return th[o + (CH_C) * w] * pressure * (3.0 * c * c - 1.0)


@kernel(error_model="numpy", inline="always")
def wall_corrected(pressure, length, th, o, w):
    """Chou–Hannaford with the wall term: + π·P·[D0·t·(2 sin θ − 1/sin θ) − t²]. [N]

    Tsagarakis & Caldwell (2000); Davis et al. (2003).
    """
    c0 = length / th[o + (CH_B) * w]
    c = -1.0 if c0 < -1.0 else c0
    c = 1.0 - 1e-12 if c > 1.0 - 1e-12 else c
    s = math.sqrt(1.0 - c * c)
    t = th[o + (CH_T) * w]
    return (th[o + (CH_C) * w] * pressure * (3.0 * c0 * c0 - 1.0)
            + math.pi * pressure * (th[o + (CH_D0) * w] * t * (2.0 * s - 1.0 / s) - t * t))


# --- the braid-angle map of eq. (2)+(3), solved for the load ------------------------------------------
# θ: Ls, k1, k2, number of loads, loads[MAP_MAX_LOADS], then per load the cubic's P³, P², P, 1 (P in MPa)
BM_LS, BM_K1, BM_K2, BM_N = range(4)
BM_LOADS = 4
BM_COEF = BM_LOADS + MAP_MAX_LOADS


@kernel(error_model="numpy", inline="always")
def _cubic(th, row, o, w, x):
    return ((th[o + (row) * w] * x + th[o + (row + 1) * w]) * x + th[o + (row + 2) * w]) * x + th[o + (row + 3) * w]


@kernel(error_model="numpy", inline="always")
def braid_map(pressure, length, th, o, w):
    """The load that holds the muscle at a length: eq. (2) for cos θ, eq. (3) linear in load. [N]

    cos θ is a cubic in P per characterized load and linear in load between them (the end
    segments extended); the segment whose cos θ interval holds the target gives the load.
    NaN where no segment does (two loads with the same cos θ). “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt),
    eq. (2)–(3), Tables I–II.
    """
    target = (length - th[o + (BM_K2) * w]) / (th[o + (BM_K1) * w] * th[o + (BM_LS) * w])
    x = pressure / MPA
    nseg = int(th[o + (BM_N) * w]) - 1
    out = math.nan
    a = _cubic(th, BM_COEF, o, w, x)
    for i in range(MAP_MAX_LOADS - 1):
        b = _cubic(th, BM_COEF + 4 * (i + 1), o, w, x)
        u = (target - a) / (b - a)
        inside = (u >= 0.0 and u <= 1.0) or (i == 0 and u < 0.0) or (i == nseg - 1 and u > 1.0)
        if i < nseg and inside and math.isnan(out) and math.isfinite(u):
            out = th[o + (BM_LOADS + i) * w] + u * (th[o + (BM_LOADS + i + 1) * w] - th[o + (BM_LOADS + i) * w])
        a = b
    return out


# --- the spring model F = K(P, Ls)·Ls (eq. 1–2 of Wickramatunge and Leephakpreeda, “Study on mechanical behaviors of pneumatic artificial muscle”, Int. J. Eng. Sci. 48 (2010) 188–198 (text: 001_9d98bcef9f07dbeb.txt)) -------------------------
# θ: h2, h1, h0 (Lu = h2·P² + h1·P + h0), split pressure, low c3, c2, c1, c0, high c3, c2, c1, c0
SP_H2, SP_H1, SP_H0, SP_SPLIT, SP_LOW, SP_HIGH = 0, 1, 2, 3, 4, 8


@kernel(error_model="numpy", inline="always")
def spring(pressure, length, th, o, w):
    """Spring model: stretch Ls = l − Lu(P), F = (c3·P + c2·P·Ls + c1·Ls + c0)·Ls, 0 when slack. [N]

    One coefficient set per pressure range (low ≤ split < high), one direction chosen when θ was
    built. Wickramatunge and Leephakpreeda, “Study on mechanical behaviors of pneumatic artificial muscle”, Int. J. Eng. Sci. 48 (2010) 188–198 (text: 001_9d98bcef9f07dbeb.txt), eq. (1)–(2), Table 1.
    """
    p = pressure
    s = length - ((th[o + (SP_H2) * w] * p + th[o + (SP_H1) * w]) * p + th[o + (SP_H0) * w])
    r = SP_LOW if p <= th[o + (SP_SPLIT) * w] else SP_HIGH
    k = th[o + (r) * w] * p + th[o + (r + 1) * w] * p * s + th[o + (r + 2) * w] * s + th[o + (r + 3) * w]
    return k * s if s >= 0.0 else 0.0


@dataclass(frozen=True)
class ForceLaw:
    """One registered force law.

    Attributes
    ----------
    name : str
        Registry name.
    kernel : numba dispatcher
        ``kernel(pressure [Pa], length [m], th, o, w) -> force [N]``, parameter r at ``th[o + r·w]``.
    citation : str
        Where the law comes from.
    """

    name: str
    kernel: object
    citation: str


#: The registry, by name, in a fixed order (the plant compiles one branch per entry).
LAWS: dict[str, ForceLaw] = {
    law.name: law for law in (
        ForceLaw("tondu-lopez", tondu_lopez, "Tondu & Lopez (2000) eq. (4), with a pressure threshold"),
        ForceLaw("chou-hannaford", chou_hannaford, "Chou & Hannaford (1996) eq. (6)"),
        ForceLaw("wall-corrected", wall_corrected, "Tsagarakis & Caldwell (2000); Davis et al. (2003)"),
        ForceLaw("braid-map", braid_map, "000_909f662a44080c85.txt eq. (2)+(3), solved for the load"),
        ForceLaw("spring", spring, "001_9d98bcef9f07dbeb.txt eq. (1)-(2)"),
    )
}
LAW_NAMES = tuple(LAWS)
LAW_INDEX = {name: i for i, name in enumerate(LAW_NAMES)}


_TL, _CH, _WC, _BM, _SP = range(5)
assert LAW_NAMES == ("tondu-lopez", "chou-hannaford", "wall-corrected", "braid-map", "spring"), \
    "a new law needs its branch in law_value"


@kernel(error_model="numpy", inline="always")
def law_value(law, pressure, length, th, o, w):
    """The registered law of index ``law`` (in :data:`LAW_NAMES`) at one gauge pressure [Pa] and length [m]. [N]

    θ at ``th[o + r·w]``. The law is picked by an integer inside compiled code, so no compiled
    function takes a kernel as an argument (such a function cannot be cached: ``mckibben._jit``).
    """
    if law == _TL:
        return tondu_lopez(pressure, length, th, o, w)
    if law == _CH:
        return chou_hannaford(pressure, length, th, o, w)
    if law == _WC:
        return wall_corrected(pressure, length, th, o, w)
    if law == _BM:
        return braid_map(pressure, length, th, o, w)
    return spring(pressure, length, th, o, w)


@kernel(error_model="numpy")
def _eval(law, p, length, th, col, w, out):
    for i in range(p.size):
        out[i] = law_value(law, p[i], length[i], th, col[i], w)


def evaluate(name: str, pressure, length, theta) -> np.ndarray:
    """A law's force at pressures and lengths (its kernel element-wise): the NumPy face.

    Parameters
    ----------
    name : str
        A name of :data:`LAWS`.
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
    p, ell = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(length, dtype=float))
    if th.ndim > 1:
        p, ell, idx = np.broadcast_arrays(p, ell, np.arange(int(np.prod(th.shape[1:]))).reshape(th.shape[1:]))
        th2 = np.ascontiguousarray(th.reshape(NTH, -1))
    else:
        idx = np.zeros(p.shape, dtype=np.int64)
        th2 = np.ascontiguousarray(th[:, None])
    # copies, not views: a broadcast view of one element passes for contiguous, and NumPy warns
    # (FutureWarning) when the compiled call reads the writeable flag of a broadcast array
    pf = np.array(p, dtype=float, order="C").ravel()
    need_speed(pf.size)
    out = np.empty(pf.size)
    _eval(LAW_INDEX[name], pf, np.array(ell, dtype=float, order="C").ravel(), th2.ravel(),
          np.array(idx, dtype=np.int64, order="C").ravel(), th2.shape[1], out)
    return out.reshape(p.shape)


# --- θ from the models' parameters ----------------------------------------------------------------


def tondu_lopez_theta(initial_radius, initial_angle, k=1.0, p_threshold=0.0, nominal_length=1.0) -> np.ndarray:
    """θ of :func:`tondu_lopez` (arrays broadcast to per-element columns).

    Parameters
    ----------
    initial_radius : array_like
        r0. [m]
    initial_angle : array_like
        α0, from the axis. [rad]
    k : array_like, default 1.0
        Contraction correction. [-]
    p_threshold : array_like, default 0.0
        Pressure below which the law pulls nothing. [Pa]
    nominal_length : array_like, default 1.0
        Rest length l0. [m]
    """
    r0, a0, k, pth, l0 = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in
                                               (initial_radius, initial_angle, k, p_threshold, nominal_length)))
    th = np.zeros((NTH,) + r0.shape)
    th[TL_R0], th[TL_A], th[TL_B] = r0, 3.0 / np.tan(a0) ** 2, 1.0 / np.sin(a0) ** 2
    th[TL_K], th[TL_PTH], th[TL_IL0] = k, pth, 1.0 / l0
    return th


def chou_hannaford_theta(strand_length, turns, wall_thickness=0.0) -> np.ndarray:
    """θ of :func:`chou_hannaford` and :func:`wall_corrected`.

    Parameters
    ----------
    strand_length : array_like
        b. [m]
    turns : array_like
        n. [-]
    wall_thickness : array_like, default 0.0
        t. [m]
    """
    b, n, t = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (strand_length, turns, wall_thickness)))
    th = np.zeros((NTH,) + b.shape)
    d0 = b / (n * np.pi)
    th[CH_B], th[CH_C], th[CH_D0], th[CH_T] = b, np.pi * d0**2 / 4.0, d0, t
    return th


def braid_map_theta(muscle) -> np.ndarray:
    """θ of :func:`braid_map` from a :class:`~mckibben.models.mpam.MiniatureMuscle`.

    Parameters
    ----------
    muscle : MiniatureMuscle
        Its kinematic fit (eq. 2) and braid-angle map (eq. 3), published or fitted.
    """
    bm = muscle.braid_map
    n = len(bm.loads)
    if not 2 <= n <= MAP_MAX_LOADS:
        raise InputError(f"{muscle.name}: the force needs a braid-angle map at 2..{MAP_MAX_LOADS} loads; it has {n}")
    th = np.zeros(NTH)
    th[BM_LS], th[BM_K1], th[BM_K2], th[BM_N] = muscle.strand_length, muscle.k1, muscle.k2, n
    th[BM_LOADS:BM_LOADS + n] = bm.loads
    th[BM_LOADS + n:BM_COEF] = bm.loads[-1]
    for i in range(MAP_MAX_LOADS):
        th[BM_COEF + 4 * i:BM_COEF + 4 * i + 4] = bm.coefficients[min(i, n - 1)]
    return th


def spring_theta(model, direction: str = "elongation") -> np.ndarray:
    """θ of :func:`spring` from a :class:`~mckibben.models.spring.SpringModel` (its eq. 2 terms).

    Parameters
    ----------
    model : SpringModel
        Coefficients with the default stiffness terms.
    direction : {"elongation", "contraction"}
        Which of the two coefficient sets (the model's hysteresis). [-]
    """
    from mckibben.models.spring import DEFAULT_TERMS, HIGH, LOW

    if tuple(model.terms) != DEFAULT_TERMS:
        raise InputError(f"spring law: only the published stiffness terms {DEFAULT_TERMS} compile; got {model.terms}")
    th = np.zeros(NTH)
    th[SP_H2], th[SP_H1], th[SP_H0], th[SP_SPLIT] = *model.h, model.split_pressure
    for row, rname in ((SP_LOW, LOW), (SP_HIGH, HIGH)):
        c = model.coefficients.get((direction, rname))
        if c is None:
            raise InputError(f"spring law: the model has no {direction} coefficients for its {rname} range")
        th[row:row + 4] = c
    return th


def law_of(model, law: str | None = None, direction: str = "elongation") -> tuple[str, np.ndarray]:
    """The registered law and θ of a static model object.

    Parameters
    ----------
    model : object
        A :class:`~mckibben.models.mpam.MiniatureMuscle` (its braid-angle map),
        :class:`~mckibben.models.physical.TonduLopez`, :class:`~mckibben.models.physical.BraidGeometry`
        (Chou–Hannaford; wall-corrected when it has a wall) or
        :class:`~mckibben.models.spring.SpringModel`.
    law : str, optional
        For a BraidGeometry: ``"chou-hannaford"`` or ``"wall-corrected"``.
    direction : str, default "elongation"
        For a SpringModel: its coefficient set. [-]

    Returns
    -------
    (str, numpy.ndarray)
        Law name and θ of shape ``(NTH,)``.
    """
    from mckibben.models.mpam import MiniatureMuscle
    from mckibben.models.physical import BraidGeometry, TonduLopez
    from mckibben.models.spring import SpringModel

    if isinstance(model, MiniatureMuscle):
        return "braid-map", braid_map_theta(model)
    if isinstance(model, TonduLopez):
        return "tondu-lopez", model.theta()
    if isinstance(model, BraidGeometry):
        name = law or ("wall-corrected" if model.wall_thickness > 0 else "chou-hannaford")
        if name not in ("chou-hannaford", "wall-corrected"):
            raise InputError(f"a braid geometry drives chou-hannaford or wall-corrected, not {name!r}")
        return name, chou_hannaford_theta(model.strand_length, model.turns, model.wall_thickness)
    if isinstance(model, SpringModel):
        return "spring", spring_theta(model, direction)
    raise InputError(f"no force law for a {type(model).__name__}; give a MiniatureMuscle, TonduLopez, "
                     "BraidGeometry or SpringModel")


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
