"""The miniature muscle's empirical model: braid-angle cubics and the kinematic length map.

Length under a hanging load follows from two fits of [mpam-characterization]: the braid angle
as a cubic in pressure per load (eq. 3, Table II) and the fitted pantograph (eq. 2, Table I).

Loads between and beyond the characterized ones
-----------------------------------------------
The paper gives each muscle's cubic at two loads (0.6 N and 2.1 N). Between them we interpolate
cos θ linearly in load; beyond them we extrapolate the same straight line and flag the result
``load_out_of_range``. A straight line through the two characterized loads is the least-assuming
model the data support: it keeps the measured trend (a heavier load holds the muscle longer), is
exact at both characterized loads, and its flag makes every extrapolation visible. With a single
characterized load the map is used as it is and any other load is flagged.

The cubics take pressure in MPa (as printed); the functions here take Pa and convert at the edge.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, UnreachableError, check_array, check_real, show_value
from mckibben.hardware import P_MAX_LIMIT
from mckibben.models.flags import Flag, flag_where, outside
from mckibben.models.geometry import MiniatureGeometry
from mckibben.models.kinematic import braid_from_length, length_from_braid
from mckibben.models.laws._base import evaluate_kernel
from mckibben.models.laws.braid_map import braid_map, braid_map_theta

MPA = 1e6  # Pa per MPa: the papers' cubics take P in MPa


@dataclass(frozen=True)
class BraidAngleMap:
    """cos θ as a cubic in pressure, one cubic per characterized load.

    Attributes
    ----------
    loads : tuple of float
        The characterized hanging loads, ascending. [N]
    coefficients : tuple of tuple of float
        Per load, the cubic's coefficients of P³, P², P, 1 with P in MPa (as printed). [-]
    pressure_range : tuple of float
        The pressure range the cubics were characterized on. [Pa]
    citation : str
        Where the numbers come from.
    """

    loads: tuple[float, ...]
    coefficients: tuple[tuple[float, float, float, float], ...]
    pressure_range: tuple[float, float] = (0.0, 0.8e6)
    citation: str = ""

    def __post_init__(self):
        if len(self.loads) != len(self.coefficients) or not self.loads:
            raise InputError("BraidAngleMap: one coefficient row per load is needed")
        if any(b <= a for a, b in zip(self.loads, self.loads[1:])):
            raise InputError("BraidAngleMap: loads must be strictly ascending")
        if any(len(row) != 4 for row in self.coefficients):
            raise InputError("BraidAngleMap: each cubic has 4 coefficients (P^3, P^2, P, 1)")

    @property
    def load_range(self) -> tuple[float, float]:
        """The characterized loads' range. [N]"""
        return (self.loads[0], self.loads[-1])

    def coefficients_at(self, load):
        """The cubic's coefficients at each load, linear in load (see module notes).

        Parameters
        ----------
        load : array_like
            Hanging load. [N]

        Returns
        -------
        numpy.ndarray
            Shape ``load.shape + (4,)``: coefficients of P³, P², P, 1 (P in MPa). [-]
        """
        load = np.asarray(load, dtype=float)
        table = np.asarray(self.coefficients, dtype=float)
        if len(self.loads) == 1:
            return np.broadcast_to(table[0], load.shape + (4,)).copy()
        loads = np.asarray(self.loads)
        # index of the segment [loads[i], loads[i+1]] used for each load; the end segments
        # are extended beyond the characterized loads.
        i = np.clip(np.searchsorted(loads, load) - 1, 0, len(loads) - 2)
        w = (load - loads[i]) / (loads[i + 1] - loads[i])
        return table[i] + w[..., None] * (table[i + 1] - table[i])


def braid_cos_theta(pressure, load, braid_map: BraidAngleMap):
    """cos θ of the braid at a pressure under a hanging load.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    load : array_like
        Hanging load. [N]
    braid_map : BraidAngleMap
        The cubics per load.

    Returns
    -------
    cos_theta : numpy.ndarray
        Cosine of the braid angle. [-]
    flags : numpy.ndarray of uint16
        :class:`~mckibben.models.flags.Flag` mask per element.

    References
    ----------
    [mpam-characterization], eq. (3) and Table II (P in MPa).
    """
    if not isinstance(braid_map, BraidAngleMap):
        raise ArgumentTypeError(f"braid_map = {braid_map!r}: not a BraidAngleMap ({type(braid_map).__name__}); "
                                "a muscle's is muscle.braid_map")
    pressure, load = np.broadcast_arrays(check_array(pressure, "pressure"), check_array(load, "load"))
    c = braid_map.coefficients_at(load)
    p = pressure / MPA
    cos_theta = ((c[..., 0] * p + c[..., 1]) * p + c[..., 2]) * p + c[..., 3]
    lo, hi = braid_map.pressure_range
    flags = (
        outside(pressure, lo, hi, Flag.PRESSURE_OUT_OF_RANGE)
        | outside(load, *braid_map.load_range, Flag.LOAD_OUT_OF_RANGE)
        | flag_where(cos_theta > 1.0, Flag.COS_THETA_ABOVE_ONE)
    )
    return cos_theta, flags


@dataclass(frozen=True)
class MiniatureMuscle:
    """A characterized miniature muscle: kinematic fit plus braid-angle cubics.

    Attributes
    ----------
    name : str
        Short name, e.g. ``"mpam97"``.
    nominal_length : float
        Un-pressurized length L0. [m]
    strand_length : float
        Length of one braid strand, Ls. [m]
    k1 : float
        Slope correction of eq. (2). [-]
    k2 : float
        Offset of eq. (2). [m]
    braid_map : BraidAngleMap
        cos θ(P) per load.
    blocked_force : tuple of (float, float)
        Published (pressure [Pa], blocked force [N]) points.
    geometry : MiniatureGeometry
        Construction (diameters, braid angle).
    citation : str
        Paper, tables and equations the numbers come from.
    """

    name: str
    nominal_length: float
    strand_length: float
    k1: float
    k2: float
    braid_map: BraidAngleMap
    blocked_force: tuple[tuple[float, float], ...] = ()
    geometry: MiniatureGeometry = field(default_factory=MiniatureGeometry)
    citation: str = ""
    synthetic: bool = False

    @property
    def outer_diameter(self) -> float:
        """Outer diameter of the braided muscle (its construction's). [m]"""
        return self.geometry.outer_diameter

    @property
    def length_stops(self) -> tuple[float, float]:
        """The braid's end stops (:func:`braid_end_stops`): no length outside them is one this muscle takes. [m]"""
        lo, hi = braid_end_stops(self.strand_length, self.k1, self.k2)
        return float(lo), float(hi)

    def length_for_pressure(self, pressure, load) -> "LengthPrediction":
        """Length at a pressure under a hanging load: :func:`predict_length` (the muscle statics' interface).

        Parameters
        ----------
        pressure : array_like
            Gauge pressure. [Pa]
        load : array_like
            Hanging load. [N]
        """
        return predict_length(self, pressure, load)

    def pressure_for_length(self, length, load, p_max: float = 0.8e6) -> "LengthPrediction":
        """The pressure that holds a length under a load: :func:`pressure_for_length` (the muscle statics' interface).

        Parameters
        ----------
        length : array_like
            Target length. [m]
        load : array_like
            Hanging load. [N]
        p_max : float, default 0.8e6
            Highest pressure allowed. [Pa]
        """
        return pressure_for_length(self, length, load, p_max)


@dataclass(frozen=True)
class LengthPrediction:
    """Result of :func:`predict_length` or :func:`pressure_for_length` (all arrays, SI)."""

    pressure: np.ndarray  #: gauge pressure [Pa]
    load: np.ndarray  #: hanging load [N]
    length: np.ndarray  #: muscle length [m]
    contraction: np.ndarray  #: 1 - l/L0 [-]
    cos_theta: np.ndarray  #: cosine of the braid angle [-]
    flags: np.ndarray  #: Flag mask per element (uint16)


def braid_end_stops(strand_length, k1, k2):
    """The braid's end stops through eq. (2): the locking angle (cos θ = 1/√3) and the straight braid (cos θ = 1).

    ``k1·Ls/√3 + k2`` and ``k1·Ls + k2`` ([mpam-characterization], eq. (2)); the one formula the
    muscle's range and the plant's end stops (:func:`mckibben.plant.packing.derive`) share.

    Parameters
    ----------
    strand_length : array_like
        Strand length Ls. [m]
    k1 : array_like
        Eq. (2)'s scale. [-]
    k2 : array_like
        Eq. (2)'s offset. [m]

    Returns
    -------
    tuple of array_like
        The locking and the straight length. [m]
    """
    k1ls = k1 * strand_length
    return k1ls / np.sqrt(3.0) + k2, k1ls + k2


#: The most elements a static model takes in one call (after broadcasting): the forward maps cost
#: about 0.2 µs and 120 B per element, so 1e7 elements answer in seconds within a few GiB. [-]
MAX_POINTS = 10**7
#: The same for the models that solve per element (the inverse cubic, the physical laws' roots and
#: bisections): 5 to 10 µs and up to 400 B per element, so 1e6 elements answer in about 10 s;
#: give more in chunks. [-]
MAX_SOLVE_POINTS = 10**6


#: Arguments of the static models that are physically positive: a length of zero or below is
#: refused rather than flagged (no muscle has one; flags are for values a muscle could take). [-]
POSITIVE_ARGUMENTS = ("length",)


def check_points(limit: int = MAX_POINTS, **arrays) -> list[np.ndarray]:
    """The named arguments as finite float arrays, broadcast together, refused past ``limit`` elements.

    Each argument is checked by :func:`~mckibben.errors.check_array` (None, bool, text, NaN and
    infinity refused, naming it), then their shapes must broadcast and the broadcast size must be
    at most ``limit``: both checked before anything of that size is allocated. A length
    (:data:`POSITIVE_ARGUMENTS`) must be above zero.

    Parameters
    ----------
    limit : int, default MAX_POINTS
        The most elements accepted. [-]
    arrays : array_like, as keyword arguments
        The arguments by their Python names, in SI. [SI]

    Returns
    -------
    list of numpy.ndarray
        The arguments as float arrays (broadcast views), in the order given. [SI]
    """
    checked = {name: check_array(value, name, size=limit) for name, value in arrays.items()}
    names = ", ".join(checked)
    empty = [n for n, a in checked.items() if a.size == 0]
    if empty:
        raise InputError(f"{empty[0]}: an empty array; give at least one value")
    for name in POSITIVE_ARGUMENTS:
        if name in checked and checked[name].min() <= 0:
            raise InputError(f"{name}: {checked[name].min():g} m is not a muscle's length; a length is > 0 "
                             "(in metres: 97 mm is 0.097)")
    try:
        shape = np.broadcast_shapes(*(a.shape for a in checked.values()))
    except ValueError:
        shapes = " and ".join(f"{n} {a.shape}" for n, a in checked.items())
        raise InputError(f"{names}: shapes {shapes} do not broadcast together") from None
    n = int(np.prod(shape, dtype=float)) if shape else 1
    if n > limit:
        raise InputError(f"{names}: {n:,} points after broadcasting, more than the {limit:,} a call takes; "
                         "give fewer, or call in chunks")
    return list(np.broadcast_arrays(*checked.values()))


def _check_muscle(muscle) -> None:
    """``muscle`` is a :class:`MiniatureMuscle` (not its name, not None): else an error naming it."""
    if not isinstance(muscle, MiniatureMuscle):
        hint = f"; get one with get_muscle({muscle!r})" if isinstance(muscle, str) else ""
        raise ArgumentTypeError(f"muscle = {show_value(muscle)}: not a MiniatureMuscle ({type(muscle).__name__}){hint}")


def predict_length(muscle: MiniatureMuscle, pressure, load) -> LengthPrediction:
    """Length and contraction of a miniature muscle at a pressure under a hanging load.

    Parameters
    ----------
    muscle : MiniatureMuscle
        The muscle's parameters (e.g. ``get_muscle("mpam97")``).
    pressure : array_like
        Gauge pressure. [Pa]
    load : array_like
        Hanging load. [N]

    Returns
    -------
    LengthPrediction
        Length [m], contraction 1 − l/L0 [-], cos θ [-] and flags, broadcast over the inputs.

    References
    ----------
    [mpam-characterization], eq. (2) with (3) and Tables I–II.

    Examples
    --------
    >>> from mckibben.datasets import get_muscle
    >>> r = predict_length(get_muscle("mpam97"), 0.8e6, 0.6)
    >>> round(float(r.length) * 1e3, 1), round(float(r.contraction), 3)
    (78.1, 0.195)
    """
    _check_muscle(muscle)
    pressure, load = check_points(MAX_POINTS, pressure=pressure, load=load)
    cos_theta, flags = braid_cos_theta(pressure, load, muscle.braid_map)
    length = length_from_braid(cos_theta, muscle.strand_length, muscle.k1, muscle.k2)
    flags = flags | flag_where(length < 0, Flag.NEGATIVE_LENGTH)
    p, f = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(load, dtype=float))
    return LengthPrediction(p, f, length, 1.0 - length / muscle.nominal_length, cos_theta, flags)


def pressure_for_length(muscle: MiniatureMuscle, length, load, p_max: float = 0.8e6) -> LengthPrediction:
    """The pressure that holds a miniature muscle at a length under a load: the inverse model.

    Solves eq. (2) for cos θ, then the load's cubic (eq. 3) for the pressure. Where the cubic
    reaches the target cos θ more than once in ``[0, p_max]`` the lowest pressure is returned
    (the first one met while inflating). Targets no pressure in ``[0, p_max]`` reaches are
    returned as NaN with the ``unreachable`` flag; :func:`require_reachable` raises instead.

    Parameters
    ----------
    muscle : MiniatureMuscle
        The muscle's parameters.
    length : array_like
        Target length. [m]
    load : array_like
        Hanging load. [N]
    p_max : float, default 0.8e6
        Highest pressure allowed (the paper's safe limit). [Pa]

    Returns
    -------
    LengthPrediction
        The pressure [Pa] (NaN where unreachable) with length, contraction, cos θ and flags.

    References
    ----------
    [mpam-characterization], eq. (2) and (3) inverted; §IV uses it as the feed-forward.
    """
    _check_muscle(muscle)
    p_max = check_real(p_max, "p_max", lo=0.0, lo_open=True, hi=P_MAX_LIMIT, unit="Pa")
    length, load = check_points(MAX_SOLVE_POINTS, length=length, load=load)
    target = braid_from_length(length, muscle.strand_length, muscle.k1, muscle.k2)
    coeffs = muscle.braid_map.coefficients_at(load)
    p_max_mpa = p_max / MPA
    pressure = _lowest_roots(coeffs.reshape(-1, 4), target.ravel(), p_max_mpa).reshape(length.shape)
    pressure *= MPA
    reached = np.isfinite(pressure)
    cos_theta, flags = braid_cos_theta(np.where(reached, pressure, 0.0), load, muscle.braid_map)
    flags = np.where(reached, flags, np.uint16(0)).astype(np.uint16)
    flags |= flag_where(~reached, Flag.UNREACHABLE)
    flags |= outside(load, *muscle.braid_map.load_range, Flag.LOAD_OUT_OF_RANGE)
    cos_theta = np.where(reached, cos_theta, target)
    return LengthPrediction(pressure, load, length, 1.0 - length / muscle.nominal_length, cos_theta, flags)


def _lowest_roots(c: np.ndarray, target: np.ndarray, p_max: float) -> np.ndarray:
    """:func:`_lowest_root` of every row of ``c`` (N, 4) and ``target`` (N,), the same arithmetic batched.

    The common case, a true cubic whose constant term is not zero, runs as one batch: the
    companion matrices ``np.roots`` builds, their eigenvalues (one LAPACK call each, as there),
    the candidates in ascending order and the same three Newton steps by Horner's rule. Rows
    ``np.roots`` would trim (a zero leading or trailing coefficient) and non-finite targets take
    the scalar path. P in MPa.
    """
    out = np.full(target.shape, np.nan)
    poly = np.empty((target.size, 4))
    poly[:, :3] = c[:, :3]
    poly[:, 3] = c[:, 3] - target
    batch = np.isfinite(target) & (poly[:, 0] != 0) & (poly[:, 3] != 0) & np.isfinite(poly).all(axis=1)
    for i in np.flatnonzero(~batch & np.isfinite(target)):
        out[i] = _lowest_root(c[i], target[i], p_max)
    if not batch.any():
        return out
    pb = poly[batch]
    comp = np.zeros((pb.shape[0], 3, 3))
    comp[:, 0, :] = -pb[:, 1:] / pb[:, :1]
    comp[:, 1, 0] = comp[:, 2, 1] = 1.0
    roots = np.linalg.eigvals(comp)
    scale = np.maximum(1.0, np.max(np.abs(roots), axis=1, keepdims=True))
    tol = 1e-9
    real = np.where(np.abs(roots.imag) <= 1e-7 * scale, roots.real, np.inf)
    cands = np.sort(np.where((real >= -tol) & (real <= p_max + tol), real, np.inf), axis=1)
    dpoly = pb[:, :3] * np.array([3.0, 2.0, 1.0])  # np.polyder
    found = np.full(pb.shape[0], np.nan)
    for k in range(3):
        live = np.isfinite(cands[:, k]) & np.isnan(found)
        p = np.where(live, cands[:, k], 0.0)  # rows without a k-th candidate are evaluated at 0 and not used
        for _ in range(3):  # Newton polish, stopped where the derivative vanishes, as the scalar path
            f = _horner(pb, p)
            df = _horner(dpoly, p)
            step = live & (df != 0)
            p = np.where(step, p - f / np.where(step, df, 1.0), p)
            live = step
        p = np.minimum(np.maximum(p, 0.0), p_max)
        ok = np.isfinite(cands[:, k]) & np.isnan(found) & (np.abs(_horner(pb, p)) <= 1e-9)
        found[ok] = p[ok]
    out[batch] = found
    return out


def _horner(poly: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``np.polyval`` of each row of ``poly`` at each ``x``: the same Horner steps."""
    y = np.zeros_like(x)
    for j in range(poly.shape[1]):
        y = y * x + poly[:, j]
    return y


def _lowest_root(c, target: float, p_max: float) -> float:
    """Lowest P in [0, p_max] with c0·P³ + c1·P² + c2·P + c3 = target, or NaN. P in MPa."""
    if not np.isfinite(target):
        return np.nan
    poly = np.array([c[0], c[1], c[2], c[3] - target])
    tol = 1e-9
    roots = np.roots(poly) if np.any(poly[:3] != 0) else np.array([])
    real = roots[np.abs(roots.imag) <= 1e-7 * max(1.0, np.max(np.abs(roots)) if roots.size else 1.0)].real
    cands = np.sort(real[(real >= -tol) & (real <= p_max + tol)])
    for p in cands:
        # Newton polish to full precision, kept inside the bracket.
        for _ in range(3):
            f = np.polyval(poly, p)
            df = np.polyval(np.polyder(poly), p)
            if df == 0:
                break
            p = p - f / df
        p = min(max(p, 0.0), p_max)
        if abs(np.polyval(poly, p)) <= 1e-9:
            return float(p)
    return np.nan


def require_reachable(result: LengthPrediction, muscle: MiniatureMuscle, p_max: float = 0.8e6) -> None:
    """Raise :class:`~mckibben.errors.UnreachableError` naming the first unreachable target.

    Parameters
    ----------
    result : LengthPrediction
        The result of :func:`pressure_for_length`.
    muscle : MiniatureMuscle
        The muscle it was computed for.
    p_max : float, default 0.8e6
        The pressure limit it was computed with. [Pa]
    """
    bad = np.flatnonzero(np.isnan(np.ravel(result.pressure)))
    if bad.size:
        i = bad[0]
        length = np.ravel(result.length)[i]
        load = np.ravel(result.load)[i]
        lo = predict_length(muscle, p_max, load).length
        hi = predict_length(muscle, 0.0, load).length
        raise UnreachableError(
            f"length {length * 1e3:.2f} mm under {load:.3g} N is unreachable for {muscle.name} with"
            f" 0..{p_max / MPA:g} MPa (the model spans {float(lo) * 1e3:.2f}..{float(hi) * 1e3:.2f} mm)"
        )


@dataclass(frozen=True)
class ForcePrediction:
    """Result of :func:`force_from_length` (arrays, SI)."""

    pressure: np.ndarray  #: gauge pressure [Pa]
    length: np.ndarray  #: muscle length [m]
    force: np.ndarray  #: pulling force that holds the muscle at that length [N]
    flags: np.ndarray  #: Flag mask per element (uint16)


def force_from_length(muscle: MiniatureMuscle, pressure, length) -> ForcePrediction:
    """The hanging load that holds a miniature muscle at a length and pressure.

    Eq. (2) gives the target cos θ from the length; cos θ is linear in load between the
    characterized loads (see the module notes), so the load follows in closed form. A load
    outside the characterized loads is flagged ``load_out_of_range``; a negative load (the muscle
    would have to push) is returned as computed and flagged ``slack``.

    Parameters
    ----------
    muscle : MiniatureMuscle
        The muscle's parameters; its braid map needs at least two characterized loads.
    pressure : array_like
        Gauge pressure. [Pa]
    length : array_like
        Muscle length. [m]

    Returns
    -------
    ForcePrediction
        Force [N] and flags, broadcast over the inputs.

    References
    ----------
    [mpam-characterization], eq. (2) and (3), Tables I–II, solved for the load.
    """
    _check_muscle(muscle)
    bmap = muscle.braid_map
    if len(bmap.loads) < 2:
        raise InputError(f"{muscle.name}: force needs cubics at two or more loads; it has {len(bmap.loads)}")
    pressure, length = check_points(MAX_SOLVE_POINTS, pressure=pressure, length=length)
    target = braid_from_length(length, muscle.strand_length, muscle.k1, muscle.k2)
    loads = np.asarray(bmap.loads)
    force = evaluate_kernel(braid_map, "braid-map", pressure, length, braid_map_theta(muscle))
    flags = (
        outside(pressure, *bmap.pressure_range, Flag.PRESSURE_OUT_OF_RANGE)
        | outside(np.nan_to_num(force, nan=loads[0]), loads[0], loads[-1], Flag.LOAD_OUT_OF_RANGE)
        | flag_where(force < 0, Flag.SLACK)
        | flag_where(target > 1, Flag.COS_THETA_ABOVE_ONE)
        | flag_where(np.isnan(force), Flag.UNREACHABLE)
    )
    return ForcePrediction(pressure, length, force, flags)
