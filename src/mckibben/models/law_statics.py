"""Statics of a muscle from any registered force law F(P, l): length under a load, pressure for a length.

A muscle known only by its force law (a lab's fitted muscle file, :mod:`mckibben.fit.muscle_file`)
has no braid-angle map to invert. Its statics are the law's two inverses, found by bracketed
root finding (Chandrupatla's method, :func:`scipy.optimize.elementwise.find_root`, all elements
at once) on the law's own kernel (:func:`mckibben.models.laws.evaluate`): no formula is written
twice.

- **Pressure for a length under a load** (:meth:`LawMuscle.pressure_for_length`): the root of
  ``F(P, l) − load`` in ``[0, p_max]``. The law pulls harder at higher pressure, so the muscle's
  pull at 0 Pa above the load means the length is longer than the unpressurized muscle holds
  under that load (it can only shorten), and its pull at ``p_max`` below the load means more
  pressure than ``p_max``: both are NaN and flagged ``unreachable``.
- **Length at a pressure under a load** (:meth:`LawMuscle.length_for_pressure`): the root of
  ``F(P, l) − load`` between the braid's end stops, the locking angle ``b/√3`` and the straight
  braid ``b`` (the ideal braid, eq. 2 with k1 = 1, k2 = 0, of the muscle's strand length ``b``:
  the same end stops the plant runs, :meth:`mckibben.plant.PlantParams.from_muscle_file`). The
  plant refuses a law whose pull falls as the muscle lengthens inside that range, so the root is
  unique. A load the law does not reach before the straight braid leaves the muscle on that end
  stop (flag ``cos_theta_above_one``); a muscle that pulls more than the load even at the
  locking angle rests on it (flag ``negative_length``); a slack muscle (load ≤ 0) is at the
  length where it just becomes taut.

Both flag lengths and pressures outside the range the law was fitted on (``length_out_of_range``,
``pressure_out_of_range``): the law is not known there.

:func:`rising_root` is the one length solver: :meth:`LawMuscle.length_for_pressure`, the statics of
every registered law on a catalogue muscle (:func:`mckibben.models.length`), the braid laws'
:func:`mckibben.models.physical.length_under_load` and the isotonic fits' lengths
(:func:`mckibben.fit.isometric.law_length`) all call it with the law's own force.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mckibben.errors import InputError
from mckibben.models import laws
from mckibben.models.flags import Flag, flag_where, outside
from mckibben.models.hysteresis.direction import DIRECTIONS, branch_force
from mckibben.models.mpam import LengthPrediction
from mckibben.models.tube import tube_force

#: Tension at which a slack muscle is taken as just taut: a slack muscle's length is where its
#: law first pulls this much. [N]
TAUT_FORCE = 1e-6
#: How far past 0 and p_max a pressure root is still taken as reached (then clipped), as the
#: miniature's inverse (:func:`mckibben.models.mpam.pressure_for_length`, 1e-9 MPa). [Pa]
PRESSURE_TOL = 1e-3


def _root(func, lo, hi, args) -> np.ndarray:
    """Roots of ``func(x, *args)`` in the brackets ``[lo, hi]`` (sign change given), element-wise."""
    from scipy.optimize.elementwise import find_root  # deferred on purpose: SciPy

    if np.size(args[0]) == 0:
        return np.empty(0)
    return np.asarray(find_root(func, (lo, hi), args=args).x, dtype=float)


#: Lengths at which :func:`rising_root` first looks for the law's pull to pass the load, and again
#: around the highest of them where it did not: a law whose pull rises, peaks and falls inside the
#: bracket (the tube wall's −1/sin θ near the straight braid) is solved on its rising branch unless
#: its peak above the load is narrower than 1/225 of the bracket (then the load is reported as never
#: reached). A law whose pull rises with length is found in the first scan. [-]
SCAN_POINTS = 16
#: Elements evaluated in one call of the law while scanning (lengths × points). [-]
SCAN_BLOCK = 1 << 21


def _scan(force, p, w, grid):
    """Per element: index of the first of ``grid`` (rows: points, then the elements' shape) where the
    pull passes the load (-1: none), and the index of the highest pull."""
    first = np.full(p.shape, -1, dtype=np.intp)
    top = np.zeros(p.shape, dtype=np.intp)
    best = np.full(p.shape, -np.inf)
    rows = max(1, SCAN_BLOCK // max(p.size, 1))
    for k0 in range(0, grid.shape[0], rows):
        with np.errstate(all="ignore"):
            g = np.asarray(force(p[None], grid[k0:k0 + rows]), dtype=float) - w[None]
        above = g > 0
        first = np.where((first < 0) & above.any(axis=0), k0 + np.argmax(above, axis=0), first)
        g = np.where(np.isnan(g), -np.inf, g)
        k = np.argmax(g, axis=0)
        gk = np.take_along_axis(g, k[None], axis=0)[0]
        top = np.where(gk > best, k0 + k, top)
        best = np.maximum(best, gk)
    return first, top


def rising_root(force, pressure, load, lo: float, hi: float, exact=None) -> tuple[np.ndarray, np.ndarray]:
    """The shortest length in ``[lo, hi]`` at which a law pulls a load: its force solved for the length.

    The law's pull ``force(P, l)`` is scanned at :data:`SCAN_POINTS` lengths from ``lo`` to ``hi``
    (and, where it never passes the load, again between the neighbours of its highest scanned
    pull); the first interval where it passes the load brackets the root, refined by Chandrupatla's
    method (:func:`scipy.optimize.elementwise.find_root`, all elements at once). The first crossing
    is the stable equilibrium of a hanging load (the pull rises with length there), also for a law
    whose pull falls again before ``hi`` (the wall-corrected braid).

    Parameters
    ----------
    force : callable
        ``force(pressure, length) -> pull`` element-wise, NumPy arrays [Pa, m -> N] (a law's NumPy
        face, :func:`mckibben.models.laws.evaluate`).
    pressure : array_like
        Gauge pressure. [Pa]
    load : array_like
        The load to pull. [N]
    lo, hi : float
        The bracket: shortest and longest length. [m]
    exact : callable, optional
        ``exact(pressure, load) -> length`` [Pa, N -> m]: the law's own closed-form inverse
        (:attr:`mckibben.models.laws.Law.length_of`; NaN where it never pulls the load), used
        instead of the scan and the root finder, with the same bracket and states.

    Returns
    -------
    length : numpy.ndarray
        The root, broadcast over ``pressure`` and ``load``; ``lo`` where the law pulls more than the
        load already at ``lo``, ``hi`` where it never reaches it. [m]
    state : numpy.ndarray
        0 where a root was found, -1 where the law pulls more at ``lo``, +1 where it never reaches the
        load (NaN pulls count as not reaching). [-]
    """
    p, w = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(load, dtype=float))
    lo, hi = float(lo), float(hi)
    if exact is not None:
        ell = np.asarray(exact(p, w), dtype=float)
        state = np.where(ell < lo, -1, np.where(ell <= hi, 0, 1))  # NaN: never reached
        return np.where(state < 0, lo, np.where(state > 0, hi, ell)), state
    grid = np.linspace(lo, hi, SCAN_POINTS)
    first, top = _scan(force, p, w, grid.reshape((-1,) + (1,) * p.ndim))
    a = np.where(first > 0, grid[np.maximum(first - 1, 0)], np.nan)
    b = np.where(first > 0, grid[np.maximum(first, 0)], np.nan)
    state = np.where(first < 0, 1, np.where(first == 0, -1, 0))
    missed = np.flatnonzero(state.ravel() > 0)
    if missed.size:  # a peak between two scanned lengths: look again around the highest
        step = (hi - lo) / (SCAN_POINTS - 1)
        centre = grid[top.ravel()[missed]]
        fine = np.linspace(np.maximum(centre - step, lo), np.minimum(centre + step, hi), SCAN_POINTS)
        pm, wm = p.ravel()[missed], w.ravel()[missed]
        f2, _ = _scan(force, pm, wm, fine)
        hit = f2 > 0  # a crossing at the window's first point would have been seen by the first scan
        rows = missed[hit]
        cols = np.flatnonzero(hit)
        a.ravel()[rows] = fine[f2[hit] - 1, cols]
        b.ravel()[rows] = fine[f2[hit], cols]
        state.ravel()[rows] = 0
    length = np.where(state < 0, lo, hi)
    inside = state == 0
    length[inside] = _root(lambda ell, pp, ww: np.asarray(force(pp, ell), dtype=float) - ww, a[inside], b[inside],
                           (p[inside], w[inside]))
    return length, state


@dataclass(frozen=True, eq=False)
class LawMuscle:
    """A muscle whose statics come from a registered force law (e.g. a lab's fitted muscle file).

    Attributes
    ----------
    name : str
        The muscle's id.
    nominal_length : float
        Un-pressurized length L0. [m]
    law : str
        A name of :data:`mckibben.models.laws.LAWS`.
    theta : numpy.ndarray
        The law's parameters, shape ``(NTH,)``. [SI]
    strand_length : float
        Strand length of the ideal braid (eq. 2, k1 = 1, k2 = 0) that sets the end stops
        ``b/√3`` and ``b``. [m]
    pressure_range : tuple of float
        Pressures the law was fitted on. [Pa]
    length_range : tuple of float
        Lengths the law was fitted on. [m]
    outer_diameter : float
        Outer diameter at rest. [m]
    direction : str, default "inflate"
        Which branch of the law (a spring law's hysteresis). [-]
    source : object, optional
        Where the law comes from (the :class:`~mckibben.data.muscle_file.MuscleSpec` of a muscle file),
        for building the same muscle's plant. [-]
    citation : str
        Where the law comes from, in words.
    tube_stiffness : float, default 0.0
        The tube's stiffness past the rest length (:mod:`mckibben.models.tube`): its pull
        k_t·max(l − L0, 0) is added to the law's. [N/m]
    friction_area : float, default 0.0
        The braid's friction area A_f (:func:`mckibben.models.hysteresis.direction.branch_force`):
        inflating the muscle pulls A_f·P less than its static force, deflating A_f·P more (the
        ``branch`` of :meth:`force` and the solvers; without one, the static force). [m²]
    friction_force : float, default 0.0
        The friction's constant part F_0 beside A_f·P (the slip limit F_0 + A_f·P). [N]
    play_threshold : float, default 0.0
        The threshold r of a play on the pressure feeding the law (the ``"play"`` direction-aware
        form, :func:`mckibben.models.hysteresis.direction.branch_force`): on a ``branch`` the law
        sees z = P − r inflating, P + r deflating; 0: no play. One operator: not with a friction. [Pa]
    """

    name: str
    nominal_length: float
    law: str
    theta: np.ndarray
    strand_length: float
    pressure_range: tuple
    length_range: tuple
    outer_diameter: float
    direction: str = "inflate"
    source: object = None
    citation: str = ""
    tube_stiffness: float = 0.0
    friction_area: float = 0.0
    friction_force: float = 0.0
    play_threshold: float = 0.0

    def __post_init__(self):
        if self.law not in laws.LAWS:
            raise InputError(f"law: {self.law!r} is not one of {', '.join(laws.LAWS)}")
        if np.shape(self.theta) != (laws.NTH,):
            raise InputError(f"theta: shape {np.shape(self.theta)}, want ({laws.NTH},)")
        b, l0 = self.strand_length, self.nominal_length
        if not (math.isfinite(b) and math.isfinite(l0) and b / math.sqrt(3.0) < l0 < b):
            raise InputError(f"strand length: {b * 1e3:.4g} mm must hold the nominal {l0 * 1e3:.4g} mm between the"
                             " braid's end stops b/√3 and b")
        for name in ("tube_stiffness", "friction_area", "friction_force", "play_threshold"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise InputError(f"{name}: {value!r} must be a finite number >= 0")
        if self.play_threshold and self.has_friction:
            raise InputError(f"play_threshold: {self.play_threshold!r} Pa with a friction (friction_area "
                             f"{self.friction_area!r}, friction_force {self.friction_force!r}); a muscle's law has one "
                             "operator, give one of them")

    @property
    def has_friction(self) -> bool:
        """Whether the muscle has a fitted friction (a ``branch`` of its loop to give). [-]"""
        return bool(self.friction_area or self.friction_force)

    @property
    def has_operator(self) -> bool:
        """Whether the muscle's law has a hysteresis operator (a fitted friction or a play): a ``branch`` of its
        loop to give. [-]"""
        return self.has_friction or bool(self.play_threshold)

    @property
    def length_stops(self) -> tuple[float, float]:
        """The braid's end stops: locking angle ``b/√3`` and straight braid ``b``. [m]"""
        return self.strand_length / math.sqrt(3.0), self.strand_length

    def _static(self, theta, pressure, length) -> np.ndarray:
        """The law's pull plus the tube's (:func:`mckibben.models.tube.tube_force`). [N]"""
        f = laws.evaluate(self.law, pressure, length, theta)
        return f + tube_force(length, self.nominal_length, self.tube_stiffness) if self.tube_stiffness else f

    def force(self, pressure, length, branch: str | None = None) -> np.ndarray:
        """The muscle's pull at pressures and lengths (negative where the law would push). [N]

        The law's pull, plus the tube's past the rest length (:attr:`tube_stiffness`); on a
        ``branch``, less (inflating) or more (deflating) by the friction F_0 + A_f·P
        (:attr:`friction_force`, :attr:`friction_area`), or the law at the play's output P ∓ r
        (:attr:`play_threshold`): :func:`mckibben.models.hysteresis.direction.branch_force`.

        Parameters
        ----------
        pressure : array_like
            Gauge pressure. [Pa]
        length : array_like
            Muscle length. [m]
        branch : {"inflate", "deflate"}, optional
            The branch of the friction's loop; None: the static (friction-free) pull. [-]
        """
        if branch is not None and branch not in DIRECTIONS:
            raise InputError(f"branch: {branch!r} must be inflate or deflate (or None: the static pull)")
        if branch is None or not self.has_operator:
            return self._static(self.theta, pressure, length)
        return branch_force(self._static, self.theta, self.friction_area, pressure, length, branch,
                            friction_force=self.friction_force, play_threshold=self.play_threshold)

    def _exact(self):
        """The law's closed-form inverse on this θ, if it has one (:attr:`mckibben.models.laws.Law.length_of`)
        and the muscle has no tube term (the inverse is the law's alone)."""
        length_of = laws.LAWS[self.law].length_of
        return None if length_of is None or self.tube_stiffness else (lambda p, w: length_of(self.theta, p, w))

    def _range_flags(self, pressure, length) -> np.ndarray:
        return (outside(pressure, *self.pressure_range, Flag.PRESSURE_OUT_OF_RANGE)
                | outside(length, *self.length_range, Flag.LENGTH_OUT_OF_RANGE)).astype(np.uint16)

    def _prediction(self, pressure, load, length, flags) -> LengthPrediction:
        return LengthPrediction(pressure, load, length, 1.0 - length / self.nominal_length,
                                length / self.strand_length, flags.astype(np.uint16))

    def length_for_pressure(self, pressure, load, branch: str | None = None) -> LengthPrediction:
        """The length at which the muscle, at a pressure, pulls a load: the law solved for the length.

        Parameters
        ----------
        pressure : array_like
            Gauge pressure. [Pa]
        load : array_like
            Tension (hanging load). [N]
        branch : {"inflate", "deflate"}, optional
            The length on the inflating or deflating branch of the operator's loop (:meth:`force`);
            None: the static length. [-]

        Returns
        -------
        LengthPrediction
            Length [m], contraction 1 − l/L0 [-], cos θ = l/b of the ideal braid [-] and flags.
        """
        p, w = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(load, dtype=float))
        lo, hi = self.length_stops
        exact = self._exact() if branch is None or not self.has_operator else None
        length, state = rising_root(lambda pp, ell: self.force(pp, ell, branch), p, np.maximum(w, TAUT_FORCE), lo, hi,
                                    exact)
        flags = (self._range_flags(p, length) | flag_where(state < 0, Flag.NEGATIVE_LENGTH)
                 | flag_where(state > 0, Flag.COS_THETA_ABOVE_ONE))
        return self._prediction(p, w, length, flags)

    def pressure_for_length(self, length, load, p_max: float, branch: str | None = None) -> LengthPrediction:
        """The pressure that holds the muscle at a length under a load: the law solved for the pressure.

        Parameters
        ----------
        length : array_like
            Target length. [m]
        load : array_like
            Tension (hanging load). [N]
        p_max : float
            Highest pressure allowed. [Pa]
        branch : {"inflate", "deflate"}, optional
            The pressure on the inflating or deflating branch of the operator's loop (:meth:`force`);
            None: the static pressure. [-]

        Returns
        -------
        LengthPrediction
            The pressure [Pa] (NaN where no pressure in ``[0, p_max]`` holds the length, or the
            length is past the braid's end stops: flag ``unreachable``) with length, contraction,
            cos θ = l/b and flags.
        """
        ell, w = np.broadcast_arrays(np.asarray(length, dtype=float), np.asarray(load, dtype=float))
        lo, hi = self.length_stops
        on_braid = (ell >= lo) & (ell <= hi)
        # the bracket reaches PRESSURE_TOL past both ends, the root is clipped back into [0, p_max]:
        # a length held at exactly 0 Pa or p_max (the workspace's faces) stays reachable after
        # round-off, as the miniature's inverse (its 1e-9 MPa tolerance)
        p_lo, p_hi = -PRESSURE_TOL, p_max + PRESSURE_TOL
        g_lo = np.where(on_braid, self.force(p_lo, ell, branch) - w, np.nan)
        g_hi = np.where(on_braid, self.force(p_hi, ell, branch) - w, np.nan)
        pressure = np.full(ell.shape, np.nan)
        pressure[g_lo == 0] = p_lo
        pressure[(g_hi == 0) & (g_lo != 0)] = p_hi
        inside = (g_lo < 0) & (g_hi > 0)
        pressure[inside] = _root(lambda pp, el, ww: self.force(pp, el, branch) - ww, p_lo, p_hi,
                                 (ell[inside], w[inside]))
        pressure = np.clip(pressure, 0.0, p_max)
        reached = np.isfinite(pressure)
        flags = (self._range_flags(np.where(reached, pressure, self.pressure_range[0]), ell)
                 | flag_where(~reached, Flag.UNREACHABLE) | flag_where(ell < lo, Flag.NEGATIVE_LENGTH)
                 | flag_where(ell > hi, Flag.COS_THETA_ABOVE_ONE))
        return self._prediction(pressure, w, ell, flags)
