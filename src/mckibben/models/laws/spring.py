"""The spring model of commercial muscles, F = K(P, Ls)·Ls: kernel, parameters, NumPy face and fit spec.

The muscle is a spring whose stiffness depends on pressure and stretch. At gauge pressure P and
no load it contracts to its *unstretched* length Lu(P), a quadratic in P (Table 1). Pulled to
length L it is stretched by Ls = L − Lu(P) and pulls back with F = K(P, Ls)·Ls (eq. 1). K is a
polynomial in (P, Ls) — by default K = c3·P + c2·P·Ls + c1·Ls + c0 (eq. 2, as we read it) — with
one coefficient set per direction (elongation dL/dt > 0, contraction dL/dt < 0: the hysteresis)
and per pressure range (low ≤ split < high). SI throughout: the coefficients have units
N/(m·Pa^i·m^j) for the term P^i·Ls^j. The inverse (length from force) and the time-series driver
are in :mod:`mckibben.models.spring`.

References
----------
Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. (1) and (2), Tables 1
and 2, §5.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from mckibben._kernels import kernel, register

from mckibben.errors import InputError, check_array
from mckibben.models.flags import Flag, flag_where, outside
from mckibben.models.laws._base import NTH, FitSpec, Law, OwnFitSpec, evaluate_kernel

# θ: h2, h1, h0 (Lu = h2·P² + h1·P + h0), split pressure, low c3, c2, c1, c0, high c3, c2, c1, c0
SP_H2, SP_H1, SP_H0, SP_SPLIT, SP_LOW, SP_HIGH = 0, 1, 2, 3, 4, 8


@kernel(error_model="numpy", inline="always")
def spring(pressure, length, th, o, w):
    """Spring model: stretch Ls = l − Lu(P), F = (c3·P + c2·P·Ls + c1·Ls + c0)·Ls, 0 when slack. [N]

    One coefficient set per pressure range (low ≤ split < high), one direction chosen when θ was
    built. Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. (1)–(2), Table 1.

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
    p = pressure
    s = length - ((th[o + (SP_H2) * w] * p + th[o + (SP_H1) * w]) * p + th[o + (SP_H0) * w])
    r = SP_LOW if p <= th[o + (SP_SPLIT) * w] else SP_HIGH
    k = th[o + (r) * w] * p + th[o + (r + 1) * w] * p * s + th[o + (r + 2) * w] * s + th[o + (r + 3) * w]
    return k * s if s >= 0.0 else 0.0


#: The published stiffness terms (eq. 2 as read): exponents (i, j) of P^i·Ls^j for c3, c2, c1, c0.
DEFAULT_TERMS: tuple[tuple[int, int], ...] = ((1, 0), (1, 1), (0, 1), (0, 0))

ELONGATION, CONTRACTION = "elongation", "contraction"
#: The spring model's directions of travel (its two hysteresis branches; not the ``inflate``/``deflate``
#: of :data:`mckibben.models.hysteresis.direction.DIRECTIONS`).
SPRING_DIRECTIONS = (ELONGATION, CONTRACTION)
LOW, HIGH = "low", "high"


@dataclass(frozen=True)
class SpringModel:
    """Parameters of the spring model for one muscle.

    Attributes
    ----------
    nominal_length : float
        Rest length L0 at zero gauge pressure and no load. [m]
    h : tuple of float
        Unstretched length Lu = h[0]·P² + h[1]·P + h[2]. [m/Pa², m/Pa, m]
    coefficients : dict
        ``{(direction, range): tuple of c}``, one coefficient per term, direction in
        ``("elongation", "contraction")`` and range in ``("low", "high")``. [N/(m·Pa^i·m^j)]
    terms : tuple of (int, int)
        Exponents (i, j) of each stiffness term P^i·Ls^j (default eq. 2). [-]
    split_pressure : float
        Pressure splitting the low and high ranges (2.5 bar in the paper). [Pa]
    pressure_range : tuple of float
        Pressures the coefficients are valid on. [Pa]
    stretch_range : tuple of float
        Stretched lengths Ls the coefficients are valid on. [m]
    citation : str
        Where the numbers come from (a paper or a fit to named data).
    """

    nominal_length: float
    h: tuple[float, float, float]
    coefficients: dict
    terms: tuple[tuple[int, int], ...] = DEFAULT_TERMS
    split_pressure: float = 2.5e5
    pressure_range: tuple[float, float] = (0.0, 5e5)
    stretch_range: tuple[float, float] = (0.0, np.inf)
    citation: str = "Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. (1)-(2)"

    def __post_init__(self):
        for key, c in self.coefficients.items():
            if key[0] not in SPRING_DIRECTIONS or key[1] not in (LOW, HIGH):
                raise InputError(f"SpringModel: bad coefficient key {key!r}; use (direction, 'low'|'high')")
            if len(c) != len(self.terms):
                raise InputError(f"SpringModel: {key} has {len(c)} coefficients for {len(self.terms)} terms")


def unstretched_length(pressure, h):
    """Length of the unloaded muscle at a pressure, Lu(P) = h2·P² + h1·P + h0.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    h : sequence of 3 float
        (h2, h1, h0). [m/Pa², m/Pa, m]

    Returns
    -------
    numpy.ndarray
        Unstretched length. [m]

    References
    ----------
    Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], Table 1.
    """
    p = check_array(pressure, "pressure", finite=False)
    return (h[0] * p + h[1]) * p + h[2]


def stiffness(pressure, stretch, coefficients, terms=DEFAULT_TERMS):
    """Stiffness K(P, Ls) = Σ c_k·P^i_k·Ls^j_k.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    stretch : array_like
        Stretched length Ls = L − Lu(P). [m]
    coefficients : sequence of float or array_like
        One coefficient per term (a trailing axis of that length for per-element sets).
        [N/(m·Pa^i·m^j)]
    terms : sequence of (int, int)
        Exponents (i, j) per term.

    Returns
    -------
    numpy.ndarray
        K. [N/m]

    References
    ----------
    Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. (2).
    """
    p = np.asarray(pressure, dtype=float)
    s = np.asarray(stretch, dtype=float)
    c = np.asarray(coefficients, dtype=float)
    return sum(c[..., k] * p**i * s**j for k, (i, j) in enumerate(terms))


def _coefficients_for(model: SpringModel, pressure, direction):
    """Per-element coefficient arrays for the range of each pressure and the given direction."""
    p = np.asarray(pressure, dtype=float)
    d = np.broadcast_to(np.asarray(direction), p.shape)
    out = np.full(p.shape + (len(model.terms),), np.nan)
    for (dname, rname), c in model.coefficients.items():
        in_range = (p <= model.split_pressure) if rname == LOW else (p > model.split_pressure)
        out[(d == dname) & in_range] = c
    return out


def spring_force(length, pressure, model: SpringModel, direction=ELONGATION):
    """Pulling force of the muscle at a length and pressure, F = K(P, Ls)·Ls.

    Parameters
    ----------
    length : array_like
        Muscle length L. [m]
    pressure : array_like
        Gauge pressure. [Pa]
    model : SpringModel
        Coefficients.
    direction : str or array_like of str
        ``"elongation"`` (dL/dt > 0) or ``"contraction"`` (dL/dt < 0).

    Returns
    -------
    force : numpy.ndarray
        Pulling force, 0 where the muscle is slack (L < Lu). [N]
    flags : numpy.ndarray
        ``slack`` where L < Lu, out-of-range flags for P and Ls.

    References
    ----------
    Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. (1) with (2) and Table 1.
    """
    length, pressure = np.broadcast_arrays(np.asarray(length, dtype=float), np.asarray(pressure, dtype=float))
    stretch = length - unstretched_length(pressure, model.h)
    if tuple(model.terms) == DEFAULT_TERMS and len(model.coefficients) == 4:
        # the compiled law (spring, above), one coefficient set per direction
        d = np.broadcast_to(np.asarray(direction), pressure.shape)
        force = np.where(d == ELONGATION, evaluate_kernel(spring, "spring", pressure, length, spring_theta(model, ELONGATION)),
                         evaluate_kernel(spring, "spring", pressure, length, spring_theta(model, CONTRACTION)))
        force = np.where(np.isin(d, SPRING_DIRECTIONS), force, np.nan)
    else:  # other stiffness terms: the general polynomial
        c = _coefficients_for(model, pressure, direction)
        force = stiffness(pressure, stretch, c, model.terms) * stretch
    flags = (
        flag_where(stretch < 0, Flag.SLACK)
        | outside(pressure, *model.pressure_range, Flag.PRESSURE_OUT_OF_RANGE)
        | outside(np.maximum(stretch, 0.0), *model.stretch_range, Flag.LENGTH_OUT_OF_RANGE)
    )
    return np.where(stretch < 0, 0.0, force), flags


def spring_theta(model, direction: str = "elongation") -> np.ndarray:
    """θ of :func:`spring` from a :class:`SpringModel` (its eq. 2 terms).

    Parameters
    ----------
    model : SpringModel
        Coefficients with the default stiffness terms.
    direction : {"elongation", "contraction"}
        Which of the two coefficient sets (the model's hysteresis). [-]
    """
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


# --- fit on isometric data --------------------------------------------------------------------------

#: The unloaded length at zero pressure, Lu(0) = h0, further than this fraction from the nominal
#: length (which is that length, by definition) is flagged. [-]
NOMINAL_TOL = 0.10

SPRING_NAMES = ("h2_m_per_Pa2", "h1_m_per_Pa", "h0_m") + tuple(
    f"c{k}_{d}" for d in ("inflate", "deflate") for k in (3, 2, 1, 0))


def spring_model_of(v, l0, pmax) -> SpringModel:
    """The fitted vector (in :data:`SPRING_NAMES` order, SI) as a one-range :class:`SpringModel`.

    Parameters
    ----------
    v : array_like
        h2, h1, h0, then c3..c0 inflate (elongation), c3..c0 deflate (contraction). [SI]
    l0 : float
        Nominal length. [m]
    pmax : float
        Top of the fitted pressure range. [Pa]
    """
    h = (float(v[0]), float(v[1]), float(v[2]))
    coeffs = {(ELONGATION, LOW): tuple(float(x) for x in v[3:7]), (CONTRACTION, LOW): tuple(float(x) for x in v[7:11])}
    return SpringModel(l0, h, coeffs, DEFAULT_TERMS, np.inf, (0.0, pmax), (0.0, np.inf), "fitted (isometric)")


def fit_spec(muscle, fmax: float, data) -> FitSpec:
    """Fit spec on isometric data: Lu(P)'s h and K's c per direction, started by variable projection.

    ``inflate`` rows are the ``elongation`` branch (the force rises at a fixed length), ``deflate``
    the ``contraction`` branch. No load-cell zero: the stretch term already gives a force at zero
    pressure. K ≥ 0 is checked at every data point (``negative_stiffness``), not forced by bounds.

    Parameters
    ----------
    muscle : MuscleSpec
        Its nominal length. [-]
    fmax : float
        Largest |force| of the data. [N]
    data : mapping
        ``pressure`` [Pa], ``held_length`` [m], ``force`` [N], ``direction`` arrays. [-]
    """
    from scipy import optimize  # deferred: SciPy's optimizers load in about a second

    p, ell, f = (np.asarray(data[k], dtype=float) for k in ("pressure", "held_length", "force"))
    direction = np.asarray(data["direction"])
    l0 = muscle.nominal_length
    # no data (a saved law read back, mckibben.fit.isometric.force_law): names and force only, one
    # pressure range to infinity and no start
    pmax = (float(np.max(p)) or 1.0) if p.size else np.inf
    lo = np.array([-np.inf, -np.inf, 0.5 * l0] + [-np.inf] * 8)
    hi = np.array([np.inf, np.inf, 1.5 * l0] + [np.inf] * 8)
    dirs = np.where(direction == "deflate", CONTRACTION, ELONGATION)

    def force(v, pressure, length, direction=None, rest_length=None):
        d = ELONGATION if direction is None else np.where(np.asarray(direction) == "deflate", CONTRACTION, ELONGATION)
        return spring_force(length, pressure, spring_model_of(v, l0, pmax), d)[0]

    def linear_c(u):
        """Variable projection: K's coefficients by least squares for Lu = L0·(u0 + u1·x + u2·x²)."""
        h = np.array([l0 * u[2] / pmax**2, l0 * u[1] / pmax, l0 * u[0]])
        stretch = np.maximum(ell - np.polyval(h, p), 0.0)
        c, r = [], np.empty_like(f)
        for dn in (ELONGATION, CONTRACTION):
            sel = dirs == dn
            if sel.sum() < 5:
                c += [0.0] * 4
                r[sel] = -f[sel]
                continue
            x = np.column_stack([p[sel] ** i * stretch[sel] ** j * stretch[sel] for i, j in DEFAULT_TERMS])
            norms = np.linalg.norm(x, axis=0)
            norms[norms == 0] = 1.0
            cs = np.linalg.lstsq(x / norms, f[sel], rcond=None)[0] / norms
            c += list(cs)
            r[sel] = x @ cs - f[sel]
        return h, np.array(c), r

    starts = []
    for free in (0.15, 0.3) if p.size else ():  # free contraction at the top pressure
        u = optimize.least_squares(lambda u: linear_c(u)[2], [1.0, 0.0, -free], method="lm", max_nfev=400).x
        h, c, _ = linear_c(u)
        starts.append(np.concatenate([h, c]))

    def physical(v):
        out = []
        stretch = ell - np.polyval(v[:3], p)
        k = np.where(dirs == ELONGATION, stiffness(p, stretch, v[3:7]), stiffness(p, stretch, v[7:11]))
        if np.any((stretch > 0) & (k < 0)):
            out.append("negative_stiffness")
        pg = np.linspace(0.0, pmax, 50)
        if np.any(np.diff(np.polyval(v[:3], pg)) > 1e-9 * l0):
            out.append("free_length_grows_with_pressure")
        if abs(v[2] - l0) > NOMINAL_TOL * l0:
            out.append("free_length_far_from_nominal")
        return out

    return FitSpec(SPRING_NAMES, lo, hi, starts, force, physical)


def from_values(values: dict, muscle, direction: str = "inflate", valid_range: dict | None = None) -> SpringModel:
    """The fitted values (by name, SI) as the :class:`SpringModel` of one branch.

    One range (the same coefficients below and above an infinite split), and the chosen branch
    under both direction keys, so whoever reads the model (the plant's law, without a direction)
    runs that branch.

    Parameters
    ----------
    values : dict
        :data:`SPRING_NAMES`. [SI]
    muscle : MuscleSpec
        The muscle the law was fitted for. [-]
    direction : {"inflate", "deflate"}, default "inflate"
        The branch. [-]
    valid_range : dict, optional
        ``pressure`` -> (min, max) the law was fitted on. [Pa]
    """
    pressure_range = (valid_range or {}).get("pressure", (0.0, np.inf))
    key = "deflate" if direction == "deflate" else "inflate"
    c = tuple(float(values[f"c{k}_{key}"]) for k in (3, 2, 1, 0))
    h = (float(values["h2_m_per_Pa2"]), float(values["h1_m_per_Pa"]), float(values["h0_m"]))
    coef = {(dn, rng): c for dn in (CONTRACTION, ELONGATION) for rng in (LOW, HIGH)}
    return SpringModel(muscle.nominal_length, h, coef, DEFAULT_TERMS, np.inf, tuple(pressure_range), (0.0, np.inf),
                       f"fitted: {muscle.path or muscle.id}")


LAW = Law(
    "spring", spring, "Wickramatunge & Leephakpreeda (2010) [wickramatunge2010] eq. (1)-(2)",
    description="F = K(P, Ls)*Ls of Wickramatunge & Leephakpreeda (2010) (Lu(P) quadratic, K per inflate/deflate)",
    params=SpringModel, theta_of=spring_theta, fit_spec=fit_spec, from_values=from_values,
    needs=("nominal_length",), branches=2,
    own_fit=OwnFitSpec(("force_length", "isotonic"),
                   "Lu(P) and K(P, Ls) per direction and pressure range (force_length, isotonic or isometric)",
                   split_pressure=True),
    c_rows={"SP_H2": SP_H2, "SP_H1": SP_H1, "SP_H0": SP_H0, "SP_SPLIT": SP_SPLIT, "SP_LOW": SP_LOW, "SP_HIGH": SP_HIGH},
)


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
