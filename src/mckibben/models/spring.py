"""The empirical spring model of commercial muscles: F = K(P, Ls)·Ls.

The muscle is a spring whose stiffness depends on pressure and stretch. At gauge pressure P and
no load it contracts to its *unstretched* length Lu(P), a quadratic in P (Table 1). Pulled to
length L it is stretched by Ls = L − Lu(P) and pulls back with F = K(P, Ls)·Ls (eq. 1). K is a
polynomial in (P, Ls) — by default K = c3·P + c2·P·Ls + c1·Ls + c0 (eq. 2, as we read it) — with
one coefficient set per direction (elongation dL/dt > 0, contraction dL/dt < 0: the hysteresis)
and per pressure range (low ≤ split < high).

The law itself (kernel, :class:`SpringModel`, :func:`spring_force`, fit spec) lives in
:mod:`mckibben.models.laws.spring`; this module adds its inverse and re-exports it.

Everything here is SI: P in Pa, lengths in m, K in N/m, so the coefficients have units
N/(m·Pa^i·m^j) for the term P^i·Ls^j. The paper's bar and cm are converted at the file edge.

Examples
--------
A spring of constant stiffness K = c0 = 1000 N/m whose unstretched length is 100 mm at any
pressure stretches 10 mm under 10 N:

>>> c = tuple(1000.0 if term == (0, 0) else 0.0 for term in DEFAULT_TERMS)
>>> m = SpringModel(nominal_length=0.1, h=(0.0, 0.0, 0.1),
...                 coefficients={(d, r): c for d in DIRECTIONS for r in (LOW, HIGH)})
>>> length, flags = spring_length(10.0, 2e5, m)
>>> round(float(length), 6), int(flags)
(0.11, 0)

References
----------
Wickramatunge & Leephakpreeda (2010) [wickramatunge2010] (Wickramatunge & Leephakpreeda, Int. J. Eng. Sci. 48, 2010), eq. (1)
and (2), Tables 1 and 2, §5. Its coefficient tables are unreadable in our copy: fit them from
data (``mckibben fit --model spring``).
"""

from __future__ import annotations

import numpy as np

from mckibben.errors import InputError
from mckibben.models.flags import Flag, flag_where, outside
from mckibben.models.laws.spring import (CONTRACTION, DEFAULT_TERMS, DIRECTIONS, ELONGATION, HIGH, LOW, SpringModel,
                                         _coefficients_for, spring_force, stiffness, unstretched_length)

__all__ = ["CONTRACTION", "DEFAULT_TERMS", "DIRECTIONS", "ELONGATION", "HIGH", "LOW", "SpringModel", "spring_force",
           "spring_length", "spring_length_series", "stiffness", "unstretched_length"]

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
    Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. (1) solved for L (§5, "determine the position/length of the
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
    Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], §5 and Fig. 8.
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
