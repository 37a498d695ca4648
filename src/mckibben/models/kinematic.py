"""Braid kinematics: the pantograph model of the braided sleeve.

References
----------
[mpam-characterization], §III.C: eq. (1) l = Ls·cos θ, eq. (2) l = k1·Ls·cos θ + k2, Table I.
"""

from __future__ import annotations


from mckibben.errors import check_array


def length_from_braid(cos_theta, strand_length, k1=1.0, k2=0.0):
    """Muscle length from the braid angle, pantograph model.

    Parameters
    ----------
    cos_theta : array_like
        Cosine of the braid angle, measured from the muscle axis. [-]
    strand_length : float or array_like
        Length of one braid strand, Ls. [m]
    k1 : float or array_like, default 1.0
        Slope correction; 1.0 is the ideal pantograph of eq. (1). [-]
    k2 : float or array_like, default 0.0
        Offset; 0.0 is the ideal pantograph of eq. (1). [m]

    Returns
    -------
    numpy.ndarray
        Muscle length l. [m]

    References
    ----------
    [mpam-characterization], eq. (1) and (2), Table I.

    Examples
    --------
    >>> round(float(length_from_braid(0.7508, 0.112, 0.92, 0.77e-3)) * 1e3, 1)
    78.1
    """
    return (k1 * check_array(strand_length, "strand_length", finite=False)
            * check_array(cos_theta, "cos_theta", finite=False) + k2)


def braid_from_length(length, strand_length, k1=1.0, k2=0.0):
    """Cosine of the braid angle for a muscle length: the inverse of :func:`length_from_braid`.

    Parameters
    ----------
    length : array_like
        Muscle length l. [m]
    strand_length : float or array_like
        Length of one braid strand, Ls. [m]
    k1 : float or array_like, default 1.0
        Slope correction of eq. (2). [-]
    k2 : float or array_like, default 0.0
        Offset of eq. (2). [m]

    Returns
    -------
    numpy.ndarray
        cos θ. Values above 1 mean no braid angle gives that length. [-]

    References
    ----------
    [mpam-characterization], eq. (2) solved for cos θ.
    """
    return ((check_array(length, "length", finite=False) - k2)
            / (k1 * check_array(strand_length, "strand_length", finite=False)))
