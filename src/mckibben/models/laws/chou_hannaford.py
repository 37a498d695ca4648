"""Chou–Hannaford, the ideal thin-walled braid: kernel, NumPy face, θ and fit spec.

F = (π·D0²·P/4)·(3cos²θ − 1), cos θ = l/b, D0 = b/(nπ). The parameter object is the braid's
geometry (:class:`~mckibben.models.geometry.BraidGeometry`), shared with the wall-corrected law
(:mod:`~mckibben.models.laws.wall_corrected`), whose fit spec is built here with the wall term.

References
----------
Chou, C.-P., Hannaford, B. (1996), Measurement and modeling of McKibben pneumatic artificial
muscles, IEEE Trans. Robot. Autom. 12(1), 90–102. doi:10.1109/70.481753, eq. (6).
"""

from __future__ import annotations

import numpy as np
from mckibben._kernels import kernel, register

from mckibben.models.flags import Flag, outside
from mckibben.models.geometry import BraidGeometry, check_geometry, miniature_geometry
from mckibben.models.laws._base import (NTH, OFFSET_FLAG, THETA_MAX, THETA_MIN, THETA_STARTS_DEG, FitSpec, Law,
                                        evaluate_kernel, geometry_params, offset_flag)

# θ: b strand length [m], c = π·D0²/4 [m²], D0 = b/(nπ) [m], t wall thickness [m]
CH_B, CH_C, CH_D0, CH_T = range(4)
#: D0 bounds as factors of the measured outer diameter. [-]
D0_FACTOR = (0.5, 4.0)
#: Wall thickness bound as a factor of the outer diameter. [-]
WALL_FACTOR = 0.25
#: Thinnest wall a fit may give, as a factor of the outer diameter: every muscle has a tube (a
#: latex tube of a 10 mm muscle is about 1 mm thick, the thinnest of a miniature one 0.1 mm of 1.2
#: mm), and a wall of 0 is the ideal braid, the other law. [-]
WALL_MIN = 0.01
#: Log-normal prior on the braid angle at rest (from the muscle's axis): median [rad] and the factor
#: of one standard deviation [-]. Braided sleeves for muscles are woven at rest angles of about
#: 18–30°: the miniature muscle's braid is ~20° ([mpam-characterization], §II), Chou & Hannaford
#: (1996) measured ~20–25° on theirs, and a sleeve wound steeper than ~30° contracts little (its
#: locking angle, 54.7°, is near). A physical order, not a number fitted to any campaign; a muscle
#: file's ``braid_angle`` replaces it.
BRAID_ANGLE_PRIOR = (float(np.deg2rad(22.0)), 1.4)
#: Factor of one standard deviation of the log-normal prior on D0, whose median is the outer
#: diameter over sin θ0 (the braid's diameter at rest, D0·sin θ0, is the outer diameter less a
#: strand or two and the tube's play: within about 1.5× of it). [-]
D0_PRIOR_FACTOR = 1.5
#: Log-normal prior on the wall thickness: median as a factor of the outer diameter [-], and the
#: factor of one standard deviation [-] (tubes of muscles are 5–20 % of their outer diameter thick:
#: a Festo 10 mm muscle's ~1 mm, the miniature muscle's ~0.15 mm of 1.2 mm). A muscle file's tube
#: sizes replace it.
WALL_PRIOR = (0.1, 2.0)
#: The load cell's zero a physical law may fit, as a fraction of the peak force: a cell that was
#: never zeroed reads up to +20 N of real pre-tension in ~320 N (6 %) on the real Festo rig
#: (PROVENANCE.md of the development data), and a zero past 10 % is no zero error but a force the law
#: misses (a pressure threshold, a friction): it sits at this bound and is flagged there. [-]
ZERO_FACTOR = 2.0 * OFFSET_FLAG


@kernel(error_model="numpy", inline="always")
def chou_hannaford(pressure, length, th, o, w):
    """Ideal thin-walled muscle: F = (π·D0²·P/4)·(3cos²θ − 1), cos θ = l/b. [N]

    Chou & Hannaford (1996), eq. (6).

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
    c = length / th[o + (CH_B) * w]
    return th[o + (CH_C) * w] * pressure * (3.0 * c * c - 1.0)


def chou_hannaford_theta(strand_length, turns, wall_thickness=0.0) -> np.ndarray:
    """θ of :func:`chou_hannaford` and of the wall-corrected law.

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


def chou_hannaford_length(theta, pressure, load) -> np.ndarray:
    """The length at which the ideal braid pulls a load: eq. (6) solved for cos θ = l/b.

    cos θ = √((F/(π·D0²·P/4) + 1)/3), at least 1/√3 (the locking angle, where the pull is zero).

    Parameters
    ----------
    theta : numpy.ndarray
        The law's θ, shape ``(NTH,)`` (:func:`chou_hannaford_theta`). [SI]
    pressure : array_like
        Gauge pressure. [Pa]
    load : array_like
        The load to pull. [N]

    Returns
    -------
    numpy.ndarray
        Length; NaN where P ≤ 0 (no pull). [m]

    References
    ----------
    Chou & Hannaford (1996), eq. (6).
    """
    p, f = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(load, dtype=float))
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.sqrt((f / (theta[CH_C] * p) + 1.0) / 3.0)
    return np.where(p > 0, c * theta[CH_B], np.nan)


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
    check_geometry(geom)
    return evaluate_kernel(chou_hannaford, "chou-hannaford", pressure, length,
                           chou_hannaford_theta(geom.strand_length, geom.turns))


def braid_spec(muscle, fmax: float, wall: bool, force_of) -> FitSpec:
    """Fit spec of a braid law: θ0 (unless known), D0, the wall t (wall law, unless the tube is known), the zero.

    Bounds: θ0 in [1°, 54.7°); D0 within [0.5, 4] × the outer diameter (D0·sin θ0 is the braid
    diameter at rest, about the outer diameter); t within [0.01, 0.25] × the outer diameter; the
    zero within ± :data:`ZERO_FACTOR` × the peak force (a load cell's plausible zero error).

    Priors (log-normal, :class:`~mckibben.models.laws._base.FitSpec`), from the muscle file's
    geometry: θ0 about :data:`BRAID_ANGLE_PRIOR`; D0 about od / sin θ0 (θ0 the muscle file's braid
    angle, else the prior's median), within a factor :data:`D0_PRIOR_FACTOR`; t about
    :data:`WALL_PRIOR`. The data overrule them where they see the parameter; where they do not (the
    ideal braid trades D0 against θ0, the wall against both) the prior holds the geometry physical
    and the fit notes ``<name>_from_prior``.

    Parameters
    ----------
    muscle : MuscleSpec
        The muscle file. [-]
    fmax : float
        Largest |force| of the data. [N]
    wall : bool
        Whether the law has the wall term. [-]
    force_of : callable
        ``force_of(pressure, length, geom)``: the law's NumPy face. [N]

    References
    ----------
    Chou & Hannaford (1996), eq. (6) and D = D0·sin θ; Tsagarakis & Caldwell (2000) (the wall).
    """
    name = "wall-corrected" if wall else "chou-hannaford"
    od, l0, theta_known = geometry_params(muscle, name)
    t_known = None
    if wall and None not in (muscle.tube_outer_diameter, muscle.tube_inner_diameter):
        t_known = 0.5 * (muscle.tube_outer_diameter - muscle.tube_inner_diameter)
    names, lo, hi = [], [], []
    priors = {}
    if theta_known is None:
        names.append("theta0_rad"), lo.append(THETA_MIN), hi.append(THETA_MAX - 1e-6)
        priors["theta0_rad"] = BRAID_ANGLE_PRIOR
    theta_med = BRAID_ANGLE_PRIOR[0] if theta_known is None else theta_known
    names.append("d0_m"), lo.append(D0_FACTOR[0] * od), hi.append(D0_FACTOR[1] * od)
    priors["d0_m"] = (float(np.clip(od / np.sin(theta_med), lo[-1], hi[-1])), D0_PRIOR_FACTOR)
    if wall and t_known is None:
        names.append("wall_m"), lo.append(WALL_MIN * od), hi.append(WALL_FACTOR * od)
        priors["wall_m"] = (WALL_PRIOR[0] * od, WALL_PRIOR[1])
    names.append("offset_N"), lo.append(-ZERO_FACTOR * fmax), hi.append(ZERO_FACTOR * fmax)

    def unpack(v):
        k = 0
        th = theta_known
        if th is None:
            th, k = v[0], 1
        d0 = v[k]
        t = (v[k + 1] if wall and t_known is None else (t_known or 0.0)) if wall else 0.0
        return th, d0, t, v[-1]

    def force(v, pressure, length, direction=None, rest_length=None):
        th, d0, t, off = unpack(v)
        b = l0 / np.cos(th)
        return force_of(pressure, length, BraidGeometry(b, b / (np.pi * d0), t)) + off

    starts = []
    for tdeg in (THETA_STARTS_DEG if theta_known is None else (None,)):
        x = []
        if theta_known is None:
            x.append(np.deg2rad(tdeg))
        x.append(priors["d0_m"][0])
        if wall and t_known is None:
            x.append(priors["wall_m"][0])
        x.append(0.0)
        starts.append(np.array(x))
    return FitSpec(tuple(names), np.array(lo), np.array(hi), starts, force, lambda v: offset_flag(v[-1], fmax),
                   priors=priors)


def braid_from_values(values: dict, muscle, wall: bool) -> BraidGeometry:
    """The fitted values (by name, SI) as a :class:`BraidGeometry` (the load cell's zero dropped).

    Parameters
    ----------
    values : dict
        ``theta0_rad`` (unless the muscle gives ``braid_angle``), ``d0_m``, ``wall_m`` (wall law,
        unless the muscle gives its tube). [SI]
    muscle : MuscleSpec
        The muscle the law was fitted for. [-]
    wall : bool
        Whether the law has the wall term. [-]
    """
    l0 = muscle.nominal_length
    th = values.get("theta0_rad", muscle.braid_angle)
    b = l0 / np.cos(th)
    t = 0.0
    if wall:
        t = values.get("wall_m", 0.5 * ((muscle.tube_outer_diameter or 0.0) - (muscle.tube_inner_diameter or 0.0)))
    return BraidGeometry(float(b), float(b / (np.pi * values["d0_m"])), float(t))


def _theta(geom: BraidGeometry, direction: str = "elongation") -> np.ndarray:
    return chou_hannaford_theta(geom.strand_length, geom.turns, geom.wall_thickness)


def braid_range_flags(geom: BraidGeometry, pressure, length, force) -> np.ndarray:
    """``length_out_of_range`` off the braid's own range, locking length (cos²θ = 1/3) to straight braid.

    Beyond it the formula still returns a number; the law does not hold there.

    Parameters
    ----------
    geom : BraidGeometry
        The braid. [-]
    pressure : numpy.ndarray
        Gauge pressure (unused: the range is the braid's). [Pa]
    length : numpy.ndarray
        Muscle length. [m]
    force : numpy.ndarray
        The law's force (unused). [N]
    """
    return outside(length, geom.locking_length, geom.strand_length, Flag.LENGTH_OUT_OF_RANGE)


LAW = Law(
    "chou-hannaford", chou_hannaford, "Chou & Hannaford (1996) eq. (6)",
    description="ideal braid, fitted braid angle at rest and D0 (+ load-cell zero)",
    params=BraidGeometry, theta_of=_theta, accepts=lambda g: not g.wall_thickness > 0,
    fit_spec=lambda muscle, fmax, data=None: braid_spec(muscle, fmax, False, chou_hannaford_force),
    from_values=lambda values, muscle, direction="inflate", valid_range=None: braid_from_values(values, muscle, False),
    needs=("nominal_length", "outer_diameter"),
    published=lambda muscle: miniature_geometry(muscle.nominal_length, muscle.geometry, wall=False),
    static_flags=braid_range_flags,
    c_rows={"CH_B": CH_B, "CH_C": CH_C},
    plant_theta=lambda col, muscle: chou_hannaford_theta(col["strand_length"], col["ch_turns"], 0.0),
    length_of=chou_hannaford_length,
)


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
