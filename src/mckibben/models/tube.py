"""The tube's passive stretch: the pull of the muscle's elastic tube stretched past its rest length.

A braided muscle's inner tube (latex, silicone) is a spring of its own: stretched past its rest
length l0 it pulls back, whatever the pressure; shorter than l0 the braid's ends carry it, and it
pulls nothing. To first order that pull is linear in the stretch,

    F_t = k_t·max(l − l0, 0),

a tube stiffness k_t ≥ 0 [N/m]. Any registered force law may carry it as an optional fitted term
(:data:`TUBE_NAME`, :func:`mckibben.fit.isometric.fit_points` with ``tube=True``): the muscle's pull
is then the law's plus this. The muscle file stores it among the law's parameters; the statics
(:class:`~mckibben.models.law_statics.LawMuscle`) add it to the law, and a plant built from the
file (:meth:`mckibben.plant.PlantParams.from_muscle_file`) runs it as its ``passive_stiffness``
(the plant's own compiled term, ``mckibben.plant.physics.muscle_force``, is this formula; a test
holds the plant's steady state to these statics).

References
----------
Klute, G. K., Hannaford, B. (2000), Accounting for elastic energy storage in McKibben artificial
muscle actuators, ASME J. Dyn. Syst. Meas. Control 122(2), 386–388: the bladder's elastic energy
added to the braid's (the linear spring is its first order). [wickramatunge2010] eq. (1): at zero
pressure the muscle's force is a stiffness times its stretch past the unstretched length,
F = K(0, Ls)·Ls, Ls = L − Lu(0), which with K constant is this term.
"""

from __future__ import annotations

import numpy as np

__all__ = ["TUBE_NAME", "TUBE_MAX_STRAIN", "tube_force", "with_tube"]

#: The tube stiffness's name among a fitted law's parameters (and in a muscle file). [N/m]
TUBE_NAME = "tube_stiffness_N_per_m"
#: The tube stiffness's upper bound in a fit: the data's peak force carried at this strain of the rest
#: length (a tube that stiff is as stiff as the braid itself; the fitted value is a few % of it). [-]
TUBE_MAX_STRAIN = 0.01


def tube_force(length, rest_length, stiffness) -> np.ndarray:
    """Pull of the tube stretched past its rest length: k_t·max(l − l0, 0).

    Parameters
    ----------
    length : array_like
        Muscle length l. [m]
    rest_length : array_like
        The tube's rest length l0 (the muscle's nominal length). [m]
    stiffness : float or array_like
        Tube stiffness k_t (≥ 0). [N/m]

    Returns
    -------
    numpy.ndarray
        Pull, broadcast over the arguments; 0 at or below the rest length. [N]

    References
    ----------
    Klute & Hannaford (2000); [wickramatunge2010] eq. (1) at zero pressure (module notes).
    """
    stretch = np.asarray(length, dtype=float) - np.asarray(rest_length, dtype=float)
    return np.asarray(stiffness, dtype=float) * np.maximum(stretch, 0.0)


def with_tube(law_force, nominal_length: float):
    """A law's force function with the tube's pull added: its last value is the tube stiffness.

    Parameters
    ----------
    law_force : callable
        ``law_force(values, pressure [Pa], length [m], direction=None, rest_length=None) -> [N]`` (a
        fit spec's ``force``). [-]
    nominal_length : float
        The rest length used where ``rest_length`` is not given. [m]

    Returns
    -------
    callable
        ``force(values, pressure, length, direction=None, rest_length=None) -> [N]``, ``values`` the
        law's followed by k_t [N/m]: ``law_force(values[:-1], …) + tube_force(length, rest, values[-1])``.
    """

    def force(values, pressure, length, direction=None, rest_length=None):
        v = np.asarray(values, dtype=float)
        rest = nominal_length if rest_length is None else rest_length
        return (np.asarray(law_force(v[:-1], pressure, length, direction, rest_length), dtype=float)
                + tube_force(length, rest, v[-1]))

    return force
