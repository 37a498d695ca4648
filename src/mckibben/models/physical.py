"""Physical baselines from braid geometry: Chou–Hannaford, Tondu–Lopez, wall thickness.

These models use no fitted data: force from pressure and geometry by the principle of virtual
work on a thin cylindrical braid. For the 1.2 mm muscle they over-predict badly (wall thickness,
elasticity and friction matter at this size), which is why the papers fit empirical maps; see
``tests/test_physical.py`` for how far.

Geometry: a braid of strand length ``b`` wound ``n`` turns around the muscle. At braid angle θ
(from the axis) the muscle is ``l = b·cos θ`` long and ``D = b·sin θ/(n·π)`` across, so
``D0 = b/(n·π)`` is the diameter at θ = 90°.

References
----------
Chou, C.-P., Hannaford, B. (1996), Measurement and modeling of McKibben pneumatic artificial
muscles, IEEE Trans. Robot. Autom. 12(1), 90–102. doi:10.1109/70.481753
Tondu, B., Lopez, P. (2000), Modeling and control of McKibben artificial muscle robot actuators,
IEEE Control Syst. Mag. 20(2), 15–38. doi:10.1109/37.833638
Tsagarakis, N., Caldwell, D. G. (2000), Improved modelling and assessment of pneumatic muscle
actuators, ICRA 2000; Davis, S. et al. (2003), Enhanced modelling and performance in braided
pneumatic muscle actuators, IJRR 22(3–4), 213–227 (wall-thickness term).
Both cited as the standard physical models in Wickramatunge and Leephakpreeda, “Study on mechanical behaviors of pneumatic artificial muscle”, Int. J. Eng. Sci. 48 (2010) 188–198 (text: 001_9d98bcef9f07dbeb.txt) §1; NOTES.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mckibben.errors import InputError
from mckibben.models import laws
from mckibben.models.flags import Flag, flag_where


@dataclass(frozen=True)
class BraidGeometry:
    """A braided muscle's geometry for the physical models.

    Attributes
    ----------
    strand_length : float
        Length of one braid strand, b. [m]
    turns : float
        Number of turns one strand makes around the muscle, n. [-]
    wall_thickness : float
        Thickness of the inner tube's wall, t (0 for the thin-wall models). [m]
    """

    strand_length: float
    turns: float
    wall_thickness: float = 0.0

    def __post_init__(self):
        if not (self.strand_length > 0 and self.turns > 0 and self.wall_thickness >= 0):
            raise InputError("BraidGeometry: strand length and turns must be > 0, wall thickness >= 0")

    @classmethod
    def from_initial(cls, length: float, diameter: float, braid_angle: float, wall_thickness: float = 0.0):
        """Geometry from the muscle at rest: its length, braid diameter and braid angle.

        Parameters
        ----------
        length : float
            Rest length l0. [m]
        diameter : float
            Braid diameter at rest, D. [m]
        braid_angle : float
            Braid angle at rest θ0, from the axis. [rad]
        wall_thickness : float, default 0.0
            Tube wall thickness. [m]
        """
        if not (length > 0 and diameter > 0 and 0 < braid_angle < np.pi / 2):
            raise InputError("BraidGeometry.from_initial: need length > 0, diameter > 0, 0 < angle < 90 deg")
        b = length / np.cos(braid_angle)
        n = b * np.sin(braid_angle) / (np.pi * diameter)
        return cls(float(b), float(n), float(wall_thickness))

    @property
    def d0(self) -> float:
        """Diameter at θ = 90°, D0 = b/(nπ). [m]"""
        return self.strand_length / (self.turns * np.pi)

    @property
    def locking_length(self) -> float:
        """Length where the thin-wall force vanishes, cos²θ = 1/3 (θ ≈ 54.7°). [m]"""
        return self.strand_length / np.sqrt(3.0)


def miniature_geometry(nominal_length: float, geometry=None, wall: bool = True) -> BraidGeometry:
    """The physical-model geometry of a miniature muscle of “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt).

    The braid diameter is the outer diameter less one strand diameter (the braid's mid-line,
    1.1 mm), the braid angle the construction's ~20° (§II), and the wall the silicone tube's
    (OD 0.9 − ID 0.5)/2 = 0.2 mm.

    Parameters
    ----------
    nominal_length : float
        Rest length. [m]
    geometry : MiniatureGeometry, optional
        Construction; the paper's by default.
    wall : bool, default True
        Include the tube wall thickness (False: thin-wall ideal).
    """
    from mckibben.models.mpam import MiniatureGeometry

    g = geometry or MiniatureGeometry()
    return BraidGeometry.from_initial(
        nominal_length,
        g.outer_diameter - g.strand_diameter,
        g.braid_angle,
        g.wall_thickness if wall else 0.0,
    )


def chou_hannaford_force(pressure, length, geom: BraidGeometry):
    """Pulling force of the ideal thin-walled muscle.

    F = (π·D0²·P/4)·(3·cos²θ − 1), cos θ = l/b.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    length : array_like
        Muscle length. [m]
    geom : BraidGeometry
        Strand length and turns (wall thickness ignored).

    Returns
    -------
    numpy.ndarray
        Force (negative below the locking length: the model would push). [N]

    References
    ----------
    Chou & Hannaford (1996), eq. (6); NOTES.md.
    """
    return laws.evaluate("chou-hannaford", pressure, length, laws.chou_hannaford_theta(geom.strand_length, geom.turns))


def wall_corrected_force(pressure, length, geom: BraidGeometry):
    """Chou–Hannaford force with the wall-thickness term.

    F = (π·D0²·P/4)(3cos²θ − 1) + π·P·[D0·t·(2 sin θ − 1/sin θ) − t²].

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    length : array_like
        Muscle length. [m]
    geom : BraidGeometry
        Strand length, turns and wall thickness t.

    Returns
    -------
    numpy.ndarray
        Force. [N]

    References
    ----------
    Tsagarakis & Caldwell (2000); Davis et al. (2003); NOTES.md.
    """
    th = laws.chou_hannaford_theta(geom.strand_length, geom.turns, geom.wall_thickness)
    return laws.evaluate("wall-corrected", pressure, length, th)


def tondu_lopez_force(pressure, contraction, initial_radius, initial_angle, k=1.0):
    """Pulling force of the Tondu–Lopez model with its contraction correction.

    F = π·r0²·P·[a·(1 − k·ε)² − b], a = 3/tan²α0, b = 1/sin²α0, ε = (L0 − L)/L0.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    contraction : array_like
        Contraction ε = 1 − L/L0. [-]
    initial_radius : float
        Braid radius at rest, r0. [m]
    initial_angle : float
        Braid angle at rest, α0, from the axis. [rad]
    k : float or array_like, default 1.0
        Correction of the contraction (k = 1: the ideal model; k > 1 reaches zero force at a
        smaller contraction, as real muscles do). [-]

    Returns
    -------
    numpy.ndarray
        Force (0 at negative gauge pressure). [N]

    References
    ----------
    Tondu & Lopez (2000), eq. (4); NOTES.md.
    """
    eps = np.asarray(contraction, dtype=float)
    th = laws.tondu_lopez_theta(initial_radius, initial_angle, k, 0.0, 1.0)
    if th.ndim > 1:  # per-element parameters: broadcast them with the inputs
        p, e, idx = np.broadcast_arrays(np.asarray(pressure, dtype=float), eps, np.arange(th[0].size).reshape(th.shape[1:]))
        return laws.evaluate("tondu-lopez", p, 1.0 - e, th.reshape(laws.NTH, -1)[:, idx])
    return laws.evaluate("tondu-lopez", pressure, 1.0 - eps, th)


def tondu_lopez_contraction(pressure, force, initial_radius, initial_angle, k=1.0):
    """Contraction at which the Tondu–Lopez muscle pulls ``force``: the model's inverse.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure (> 0). [Pa]
    force : array_like
        Pulling force (the hanging load). [N]
    initial_radius, initial_angle, k
        As in :func:`tondu_lopez_force`. [m], [rad], [-]

    Returns
    -------
    contraction : numpy.ndarray
        ε = 1 − L/L0 (negative: the load stretches the muscle beyond its rest length). [-]
    flags : numpy.ndarray
        ``slack`` where the pressure is zero (the model has no stiffness then).

    References
    ----------
    Tondu & Lopez (2000), eq. (4) solved for ε.
    """
    p, f = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(force, dtype=float))
    a = 3.0 / np.tan(initial_angle) ** 2
    b = 1.0 / np.sin(initial_angle) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        q = (f / (np.pi * initial_radius**2 * p) + b) / a
        eps = (1.0 - np.sqrt(q)) / k
    bad = ~(p > 0) | ~(q >= 0)
    return np.where(bad, np.nan, eps), flag_where(bad, Flag.SLACK)


@dataclass(frozen=True)
class TonduLopez:
    """A Tondu–Lopez muscle with a pressure threshold: the plant's calibrated law as a static model.

    F = π·r0²·max(P − P_th, 0)·[a(1 − k·ε)² − b], a = 3/tan²α0, b = 1/sin²α0, ε = 1 − l/l0.

    Attributes
    ----------
    initial_radius : float
        r0. [m]
    initial_angle : float
        α0, from the axis. [rad]
    k : float
        Contraction correction. [-]
    p_threshold : float
        Pressure the tube takes before the braid moves. [Pa]
    nominal_length : float
        Rest length l0. [m]
    citation : str
        Where the numbers come from.
    """

    initial_radius: float
    initial_angle: float
    k: float = 1.0
    p_threshold: float = 0.0
    nominal_length: float = 0.097
    citation: str = "Tondu & Lopez (2000), eq. (4)"

    def theta(self) -> np.ndarray:
        """Parameters of :func:`mckibben.models.laws.tondu_lopez`. [SI]"""
        return laws.tondu_lopez_theta(self.initial_radius, self.initial_angle, self.k, self.p_threshold,
                                      self.nominal_length)

    def force(self, pressure, length):
        """Pulling force at a gauge pressure [Pa] and length [m] (the law's raw value). [N]"""
        return laws.evaluate("tondu-lopez", pressure, length, self.theta())

    def length_under_load(self, pressure, load):
        """Equilibrium length under a hanging load [N] at a gauge pressure [Pa]; NaN with ``slack``
        where the muscle pulls no load (P ≤ P_th). [m]"""
        eps, flags = tondu_lopez_contraction(np.asarray(pressure, dtype=float) - self.p_threshold, load,
                                             self.initial_radius, self.initial_angle, self.k)
        return self.nominal_length * (1.0 - eps), flags


def length_under_load(pressure, load, geom: BraidGeometry, model: str = "chou-hannaford"):
    """Equilibrium length of a physical model holding a hanging load.

    Solves F(P, l) = load for l: closed form for Chou–Hannaford (cos θ in (1/√3, 1)),
    bisection (60 halvings) for the wall-corrected force on its rising branch (from θ = 90° to
    the peak of F/P, beyond which the −1/sin θ term makes it fall).

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    load : array_like
        Hanging load. [N]
    geom : BraidGeometry
        Braid geometry.
    model : {"chou-hannaford", "wall-corrected"}
        Which force law.

    Returns
    -------
    length : numpy.ndarray
        Equilibrium length (capped at the strand length b where the load would straighten the
        braid, flagged). [m]
    flags : numpy.ndarray
        ``length_out_of_range`` where capped; ``slack`` where P = 0.
    """
    p, f = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(load, dtype=float))
    if model == "chou-hannaford":
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.sqrt((4.0 * f / (np.pi * geom.d0**2 * p) + 1.0) / 3.0)
    elif model == "wall-corrected":
        # F/P depends on cos θ only and peaks before cos θ = 1 (the −1/sin θ term): the
        # equilibrium is on the rising branch between the locking angle and that peak.
        c_peak = _wall_force_peak(geom)
        # F/P = −π(D0/2 − t)² < 0 at θ = 90° (cos θ = 0), so the branch starts below any load.
        lo = np.zeros(p.shape)
        hi = np.full(p.shape, c_peak)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            above = wall_corrected_force(p, mid * geom.strand_length, geom) > f
            hi = np.where(above, mid, hi)
            lo = np.where(above, lo, mid)
        c = 0.5 * (lo + hi)
        c = np.where(wall_corrected_force(p, c_peak * geom.strand_length, geom) < f, np.inf, c)
    else:
        raise InputError(f"length_under_load: unknown model {model!r}; use chou-hannaford or wall-corrected")
    slack = ~(p > 0)
    capped = ~(c <= 1.0) | slack
    length = np.where(capped, geom.strand_length, c * geom.strand_length)
    flags = flag_where(capped, Flag.LENGTH_OUT_OF_RANGE) | flag_where(slack, Flag.SLACK)
    return length, flags


def _wall_force_peak(geom: BraidGeometry) -> float:
    """cos θ where the wall-corrected force per unit pressure peaks. [-]"""
    from scipy.optimize import minimize_scalar

    res = minimize_scalar(
        lambda c: -float(wall_corrected_force(1.0, c * geom.strand_length, geom)),
        bounds=(1.0 / np.sqrt(3.0), 1.0 - 1e-9),
        method="bounded",
        options={"xatol": 1e-12},
    )
    return float(res.x)
