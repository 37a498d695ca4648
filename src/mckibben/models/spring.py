"""The empirical spring model of commercial muscles: F = K(P, Ls)·Ls.

The muscle is a spring whose stiffness depends on pressure and stretch. At gauge pressure P and
no load it contracts to its *unstretched* length Lu(P), a quadratic in P (Table 1). Pulled to
length L it is stretched by Ls = L − Lu(P) and pulls back with F = K(P, Ls)·Ls (eq. 1). K is a
polynomial in (P, Ls) — by default K = c3·P + c2·P·Ls + c1·Ls + c0 (eq. 2, as we read it) — with
one coefficient set per direction (elongation dL/dt > 0, contraction dL/dt < 0: the hysteresis)
and per pressure range (low ≤ split < high).

Everything here is SI: P in Pa, lengths in m, K in N/m, so the coefficients have units
N/(m·Pa^i·m^j) for the term P^i·Ls^j. The paper's bar and cm are converted at the file edge.

References
----------
Wickramatunge and Leephakpreeda, “Study on mechanical behaviors of pneumatic artificial muscle”, Int. J. Eng. Sci. 48 (2010) 188–198 (text: 001_9d98bcef9f07dbeb.txt) (Wickramatunge & Leephakpreeda, Int. J. Eng. Sci. 48, 2010), eq. (1)
and (2), Tables 1 and 2, §5. Its coefficient tables are unreadable in our copy: fit them from
data (``mckibben fit --model spring``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mckibben.errors import InputError
from mckibben.models import laws
from mckibben.models.flags import Flag, flag_where, outside

#: The published stiffness terms (eq. 2 as read): exponents (i, j) of P^i·Ls^j for c3, c2, c1, c0.
DEFAULT_TERMS: tuple[tuple[int, int], ...] = ((1, 0), (1, 1), (0, 1), (0, 0))

ELONGATION, CONTRACTION = "elongation", "contraction"
DIRECTIONS = (ELONGATION, CONTRACTION)
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
    citation: str = "001_9d98bcef9f07dbeb.txt, eq. (1)-(2)"

    def __post_init__(self):
        for key, c in self.coefficients.items():
            if key[0] not in DIRECTIONS or key[1] not in (LOW, HIGH):
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
    Wickramatunge and Leephakpreeda, “Study on mechanical behaviors of pneumatic artificial muscle”, Int. J. Eng. Sci. 48 (2010) 188–198 (text: 001_9d98bcef9f07dbeb.txt), Table 1.
    """
    p = np.asarray(pressure, dtype=float)
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
    Wickramatunge and Leephakpreeda, “Study on mechanical behaviors of pneumatic artificial muscle”, Int. J. Eng. Sci. 48 (2010) 188–198 (text: 001_9d98bcef9f07dbeb.txt), eq. (2).
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
    Wickramatunge and Leephakpreeda, “Study on mechanical behaviors of pneumatic artificial muscle”, Int. J. Eng. Sci. 48 (2010) 188–198 (text: 001_9d98bcef9f07dbeb.txt), eq. (1) with (2) and Table 1.
    """
    length, pressure = np.broadcast_arrays(np.asarray(length, dtype=float), np.asarray(pressure, dtype=float))
    stretch = length - unstretched_length(pressure, model.h)
    if tuple(model.terms) == DEFAULT_TERMS and len(model.coefficients) == 4:
        # the compiled law (mckibben.models.laws.spring), one coefficient set per direction
        d = np.broadcast_to(np.asarray(direction), pressure.shape)
        force = np.where(d == ELONGATION, laws.evaluate("spring", pressure, length, laws.spring_theta(model, ELONGATION)),
                         laws.evaluate("spring", pressure, length, laws.spring_theta(model, CONTRACTION)))
        force = np.where(np.isin(d, DIRECTIONS), force, np.nan)
    else:  # other stiffness terms: the general polynomial
        c = _coefficients_for(model, pressure, direction)
        force = stiffness(pressure, stretch, c, model.terms) * stretch
    flags = (
        flag_where(stretch < 0, Flag.SLACK)
        | outside(pressure, *model.pressure_range, Flag.PRESSURE_OUT_OF_RANGE)
        | outside(np.maximum(stretch, 0.0), *model.stretch_range, Flag.LENGTH_OUT_OF_RANGE)
    )
    return np.where(stretch < 0, 0.0, force), flags


def spring_length(force, pressure, model: SpringModel, direction=ELONGATION, max_stretch=None):
    """Length at which the muscle pulls ``force`` at ``pressure``: the model solved for L.

    For the default terms F = (c1 + c2·P)·Ls² + (c0 + c3·P)·Ls is a quadratic in Ls, solved in
    closed form (the non-negative root); other term lists are solved by bisection on
    ``[0, max_stretch]``, where F must rise with Ls.

    Parameters
    ----------
    force : array_like
        Pulling force (≥ 0). [N]
    pressure : array_like
        Gauge pressure. [Pa]
    model : SpringModel
        Coefficients.
    direction : str or array_like of str
        ``"elongation"`` or ``"contraction"``.
    max_stretch : float, optional
        Largest stretch searched by bisection; default the nominal length. [m]

    Returns
    -------
    length : numpy.ndarray
        L = Lu(P) + Ls (NaN where no stretch gives the force). [m]
    flags : numpy.ndarray
        ``unreachable`` where NaN; range flags.

    References
    ----------
    Wickramatunge and Leephakpreeda, “Study on mechanical behaviors of pneumatic artificial muscle”, Int. J. Eng. Sci. 48 (2010) 188–198 (text: 001_9d98bcef9f07dbeb.txt), eq. (1) solved for L (§5, "determine the position/length of the
    PAM when the pulling force exerts on the PAM").
    """
    force, pressure = np.broadcast_arrays(np.asarray(force, dtype=float), np.asarray(pressure, dtype=float))
    c = _coefficients_for(model, pressure, direction)
    if tuple(model.terms) == DEFAULT_TERMS:
        a2 = c[..., 2] + c[..., 1] * pressure  # c1 + c2·P
        a1 = c[..., 3] + c[..., 0] * pressure  # c0 + c3·P
        with np.errstate(divide="ignore", invalid="ignore"):
            disc = a1**2 + 4.0 * a2 * force
            root = np.where(
                np.abs(a2) > 1e-300,
                2.0 * force / (a1 + np.sqrt(np.maximum(disc, 0.0))),  # stable form of the + root
                force / a1,
            )
        stretch = np.where((disc >= 0) & (root >= 0), root, np.nan)
    else:
        hi_s = model.nominal_length if max_stretch is None else max_stretch
        lo = np.zeros(force.shape)
        hi = np.full(force.shape, hi_s)
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            above = stiffness(pressure, mid, c, model.terms) * mid > force
            hi = np.where(above, mid, hi)
            lo = np.where(above, lo, mid)
        stretch = 0.5 * (lo + hi)
        reach = stiffness(pressure, hi_s, c, model.terms) * hi_s >= force
        stretch = np.where(reach, stretch, np.nan)
    length = unstretched_length(pressure, model.h) + stretch
    flags = (
        flag_where(np.isnan(length), Flag.UNREACHABLE)
        | outside(pressure, *model.pressure_range, Flag.PRESSURE_OUT_OF_RANGE)
        | outside(np.nan_to_num(stretch), *model.stretch_range, Flag.LENGTH_OUT_OF_RANGE)
    )
    return length, flags


def spring_length_series(pressure, force, model: SpringModel, initial_direction=ELONGATION):
    """Run a force/pressure time series through the model to a length time series.

    The direction follows the force: a rising pull stretches the muscle (elongation), a falling
    pull lets it contract; when the force holds still the last direction is kept. This is how the
    paper's case studies (Fig. 8) drive the model.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure per sample. [Pa]
    force : array_like
        Pulling force per sample. [N]
    model : SpringModel
        Coefficients for both directions.
    initial_direction : str
        Direction assumed until the force first changes.

    Returns
    -------
    length : numpy.ndarray
        Length per sample. [m]
    direction : numpy.ndarray of str
        The coefficient set used per sample.
    flags : numpy.ndarray
        Flags per sample.

    References
    ----------
    Wickramatunge and Leephakpreeda, “Study on mechanical behaviors of pneumatic artificial muscle”, Int. J. Eng. Sci. 48 (2010) 188–198 (text: 001_9d98bcef9f07dbeb.txt), §5 and Fig. 8.
    """
    p = np.asarray(pressure, dtype=float).ravel()
    f = np.asarray(force, dtype=float).ravel()
    if p.shape != f.shape:
        raise InputError(f"spring_length_series: pressure has {p.size} samples, force {f.size}")
    if initial_direction not in DIRECTIONS:
        raise InputError(f"spring_length_series: initial_direction must be one of {DIRECTIONS}")
    df = np.diff(f, prepend=f[:1])
    code = np.where(df > 0, 1, np.where(df < 0, -1, 0))
    # carry the last non-zero direction forward
    idx = np.where(code != 0, np.arange(code.size), -1)
    idx = np.maximum.accumulate(idx)
    start = 1 if initial_direction == ELONGATION else -1
    carried = np.where(idx >= 0, code[np.maximum(idx, 0)], start)
    direction = np.where(carried > 0, ELONGATION, CONTRACTION)
    length, flags = spring_length(f, p, model, direction)
    return length, direction, flags
