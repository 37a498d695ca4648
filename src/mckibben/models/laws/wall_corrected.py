"""Chou–Hannaford with the tube wall's thickness: kernel, NumPy face and fit spec.

F = (π·D0²·P/4)(3cos²θ − 1) + π·P·[D0·t·(2 sin θ − 1/sin θ) − t²], on the braid geometry and
θ layout of :mod:`~mckibben.models.laws.chou_hannaford`.

References
----------
Tsagarakis, N., Caldwell, D. G. (2000), Improved modelling and assessment of pneumatic muscle
actuators, ICRA 2000; Davis, S. et al. (2003), Enhanced modelling and performance in braided
pneumatic muscle actuators, IJRR 22(3–4), 213–227 (the wall term).
"""

from __future__ import annotations

import math

import numpy as np
from mckibben._kernels import kernel, register

from mckibben.models.geometry import BraidGeometry, check_geometry, miniature_geometry
from mckibben.models.laws._base import Law, evaluate_kernel
from mckibben.models.laws.chou_hannaford import (CH_B, CH_C, CH_D0, CH_T, _theta, braid_from_values, braid_range_flags,
                                                 braid_spec, chou_hannaford_theta)


@kernel(error_model="numpy", inline="always")
def wall_corrected(pressure, length, th, o, w):
    """Chou–Hannaford with the wall term: + π·P·[D0·t·(2 sin θ − 1/sin θ) − t²]. [N]

    Tsagarakis & Caldwell (2000); Davis et al. (2003).

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
    c0 = length / th[o + (CH_B) * w]
    c = -1.0 if c0 < -1.0 else c0
    c = 1.0 - 1e-12 if c > 1.0 - 1e-12 else c
    s = math.sqrt(1.0 - c * c)
    t = th[o + (CH_T) * w]
    return (th[o + (CH_C) * w] * pressure * (3.0 * c0 * c0 - 1.0)
            + math.pi * pressure * (th[o + (CH_D0) * w] * t * (2.0 * s - 1.0 / s) - t * t))


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
    check_geometry(geom)
    th = chou_hannaford_theta(geom.strand_length, geom.turns, geom.wall_thickness)
    return evaluate_kernel(wall_corrected, "wall-corrected", pressure, length, th)


#: Bisection steps for :func:`peak_length`: [0, 1] halved to round-off. [-]
PEAK_STEPS = 64


def peak_length(theta) -> float:
    """The length where the wall-corrected pull peaks as the muscle is stretched, at every pressure. [m]

    At a pressure P the force is P·g(cos θ), g = (π·D0²/4)(3cos²θ − 1) + π·[D0·t·(2 sin θ − 1/sin θ)
    − t²], cos θ = l/b, and dg/d cos θ = π·D0·cos θ·[1.5·D0 − t·(2 + 1/sin²θ)/sin θ]: the pull rises
    with length while 1.5·D0·sin³θ > t·(2 sin²θ + 1) and falls beyond, to −∞ at the straight braid
    (the −1/sin θ term), where a stretched muscle would pull less: a negative stiffness no load rests
    on, and the thin-wall derivation's end. The cubic 1.5·D0·s³ − 2t·s² − t has one positive root
    s* (one sign change), found by bisection on [0, 1]; the peak is at l* = b·√(1 − s*²) (0 when
    the pull falls everywhere, a wall of half D0 or more; b without a wall).

    Parameters
    ----------
    theta : array_like
        The law's θ, shape ``(NTH,)`` (:func:`~mckibben.models.laws.chou_hannaford.chou_hannaford_theta`). [SI]

    Returns
    -------
    float
        l*. [m]

    References
    ----------
    Tsagarakis & Caldwell (2000); Davis et al. (2003) (the force; its derivative here is ours).
    """
    th = np.asarray(theta, dtype=float)
    b, d0, t = float(th[CH_B]), float(th[CH_D0]), float(th[CH_T])
    if not t > 0:
        return b
    lo, hi = 0.0, 1.0
    for _ in range(PEAK_STEPS):
        mid = 0.5 * (lo + hi)
        if 1.5 * d0 * mid**3 > t * (2.0 * mid**2 + 1.0):
            hi = mid
        else:
            lo = mid
    return b * math.sqrt(1.0 - hi * hi)


LAW = Law(
    "wall-corrected", wall_corrected, "Tsagarakis & Caldwell (2000); Davis et al. (2003)",
    description="Chou-Hannaford with the tube wall (fitted unless the tube sizes are in the muscle file)",
    aliases=("wall-chou-hannaford",), params=BraidGeometry, theta_of=_theta, accepts=lambda g: g.wall_thickness > 0,
    fit_spec=lambda muscle, fmax, data=None: braid_spec(muscle, fmax, True, wall_corrected_force),
    from_values=lambda values, muscle, direction="inflate", valid_range=None: braid_from_values(values, muscle, True),
    needs=("nominal_length", "outer_diameter"),
    published=lambda muscle: miniature_geometry(muscle.nominal_length, muscle.geometry, wall=True),
    static_flags=braid_range_flags, peak_length=peak_length,
    c_rows={"CH_B": CH_B, "CH_C": CH_C, "CH_D0": CH_D0, "CH_T": CH_T},
    plant_theta=lambda col, muscle: chou_hannaford_theta(col["strand_length"], col["ch_turns"], col["wall_thickness"]),
)


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
