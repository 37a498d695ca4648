"""The miniature muscle's braid-angle map of eq. (2)+(3), solved for the load: kernel and θ.

cos θ is a cubic in P per characterized load (eq. 3, Table II) and linear in load between them;
the fitted pantograph (eq. 2, Table I) turns a length into the target cos θ. The parameter object
is a :class:`~mckibben.models.mpam.MiniatureMuscle` (anything with ``strand_length``, ``k1``,
``k2`` and a ``braid_map`` of ``loads`` and ``coefficients``); it is fitted by the isotonic fits
of :mod:`mckibben.fit.static`, not by an isometric fit spec.

References
----------
[mpam-characterization], eq. (2)–(3), Tables I–II.
"""

from __future__ import annotations

import math

import numpy as np
from mckibben._kernels import kernel, register

from mckibben.errors import InputError
from mckibben.models.flags import Flag, flag_where, outside
from mckibben.models.kinematic import braid_from_length
from mckibben.models.laws._base import MAP_MAX_LOADS, MPA, NTH, Law

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
    NaN where no segment does (two loads with the same cos θ). [mpam-characterization],
    eq. (2)–(3), Tables I–II.

    Parameters
    ----------
    pressure : float
        Gauge pressure. [Pa]
    length : float
        Muscle length. [m]
    th : numpy.ndarray
        The parameter array (parameter r of this instance at ``th[o + r·w]``; :data:`NTH` rows). [-]
    o : int
        This instance's column in ``th``. [-]
    w : int
        The row stride of ``th`` (the number of instances). [-]
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


def map_flags(muscle, pressure, length, force) -> np.ndarray:
    """Where the map does not hold: a load outside its characterized loads, a braid longer than straight.

    Parameters
    ----------
    muscle : MiniatureMuscle
        The muscle (its map, strand length and pantograph). [-]
    pressure : numpy.ndarray
        Gauge pressure (unused). [Pa]
    length : numpy.ndarray
        Muscle length. [m]
    force : numpy.ndarray
        The law's force. [N]
    """
    loads = np.asarray(muscle.braid_map.loads, dtype=float)
    target = braid_from_length(length, muscle.strand_length, muscle.k1, muscle.k2)
    return (outside(np.nan_to_num(force, nan=loads[0]), loads[0], loads[-1], Flag.LOAD_OUT_OF_RANGE)
            | flag_where(target > 1, Flag.COS_THETA_ABOVE_ONE))


LAW = Law(
    "braid-map", braid_map, "[mpam-characterization] eq. (2)+(3), solved for the load",
    description="the miniature muscle's braid-angle cubics (eq. 3) and pantograph (eq. 2), solved for the load",
    aliases=("empirical", "mpam"), theta_of=lambda m, direction="elongation": braid_map_theta(m),
    accepts=lambda m: hasattr(m, "braid_map") and hasattr(m, "k1"),
    needs=("nominal_length", "strand_length"), published=lambda muscle: muscle, static_flags=map_flags,
    c_rows={"BM_LS": BM_LS, "BM_K1": BM_K1, "BM_K2": BM_K2, "BM_N": BM_N, "BM_LOADS": BM_LOADS, "BM_COEF": BM_COEF,
            "MAP_MAX_LOADS": MAP_MAX_LOADS},
    # the plant's catalogue muscle's map, the same for every instance
    plant_theta=lambda col, muscle: np.repeat(braid_map_theta(muscle())[:, None], np.size(col["nominal_length"]),
                                              axis=1),
)


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
