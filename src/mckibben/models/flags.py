"""Flags that travel with every model evaluation.

A model never hides a doubtful result: each element of an evaluation carries a bit mask of
:class:`Flag` values. ``flag_names(mask)`` turns one element's mask into the list printed by the
CLI (empty when everything is in range).
"""

from __future__ import annotations

import enum

import numpy as np

from mckibben.errors import ArgumentTypeError


class Flag(enum.IntFlag):
    """Why a predicted value deserves doubt. Combine with ``|``; stored as ``uint16`` arrays."""

    #: Pressure outside the range the model was characterized or fitted on.
    PRESSURE_OUT_OF_RANGE = 1
    #: Load outside the characterized loads; the map was extrapolated in load.
    LOAD_OUT_OF_RANGE = 2
    #: cos(theta) above 1: no braid angle gives it (e.g. Table II's delta97 at P = 0).
    COS_THETA_ABOVE_ONE = 4
    #: A negative length (or a length below the braid's locking length).
    NEGATIVE_LENGTH = 8
    #: Length outside the range the model was characterized or fitted on.
    LENGTH_OUT_OF_RANGE = 16
    #: The target cannot be reached with pressure within [0, p_max].
    UNREACHABLE = 32
    #: The muscle is slack: the model would need it to push (negative force).
    SLACK = 64
    #: Force outside the range the model was characterized or fitted on.
    FORCE_OUT_OF_RANGE = 128
    #: A family law asked for a muscle whose rest length lies outside the rest lengths it was fitted on.
    REST_LENGTH_OUT_OF_RANGE = 256


FLAG_NAMES = {
    Flag.PRESSURE_OUT_OF_RANGE: "pressure_out_of_range",
    Flag.LOAD_OUT_OF_RANGE: "load_out_of_range",
    Flag.COS_THETA_ABOVE_ONE: "cos_theta_above_one",
    Flag.NEGATIVE_LENGTH: "negative_length",
    Flag.LENGTH_OUT_OF_RANGE: "length_out_of_range",
    Flag.UNREACHABLE: "unreachable",
    Flag.SLACK: "slack",
    Flag.FORCE_OUT_OF_RANGE: "force_out_of_range",
    Flag.REST_LENGTH_OUT_OF_RANGE: "rest_length_out_of_range",
}


#: The flags a fit can carry (strings in ``FitResult.flags``): each says why the fit's **predictions**
#: deserve doubt, so a comparison does not recommend a fit that carries one. Model-specific physics
#: flags (``large_offset``, ``negative_stiffness``, ...) are named in the law's own file.
FIT_FLAGS = {
    "<name>_at_lower_bound": "a bound binds: the fit would go beyond it (one-sided bounds included)",
    "<name>_at_upper_bound": "a bound binds: the fit would go beyond it",
    "<name>_unconstrained": "the data do not constrain the parameter: its 95 % interval, even with every other "
                            "parameter held, is wider than its bound span (or its magnitude)",
    "r2_below_0.5": "the model explains less than half the variance",
    "heldout_far_above_insample": "held-out error more than HELDOUT_RATIO times the in-sample error (the interpolating folds)",
}

#: Notes a fit can carry (strings in ``FitResult.notes``): worth reporting, but no doubt about the
#: predictions on their own, so a comparison still ranks the fit on its held-out error.
FIT_NOTES = {
    "<name>_from_prior": "the parameter's value is held by its stated prior more than by the data "
                         "(mckibben.fit.core.bounded_fit, priors)",
    "correlated_parameters": "parameters trade off (the column-scaled Jacobian's condition number exceeds "
                             "COND_FLAG): their separate intervals are wide, the predictions are not",
    "negative_area": "a virtual-work law's effective area is negative at a corner of the measured box "
                     "(the held-out error says whether its predictions suffer)",
}


def split_fit_flags(names) -> tuple[tuple, tuple]:
    """Split fit flags into the ones that doubt predictions (``flags``) and :data:`FIT_NOTES` (``notes``).

    Parameters
    ----------
    names : sequence of str
        Flags as a fit or a law's physics checks produced them. [-]

    Returns
    -------
    flags, notes : tuple of str
    """
    names = tuple(names)
    return tuple(n for n in names if n not in FIT_NOTES), tuple(n for n in names if n in FIT_NOTES)


def flag_names(mask: int) -> list[str]:
    """The names of the flags set in one element's mask, in a fixed order.

    Parameters
    ----------
    mask : int
        One element of a flag array. [-]
    """
    import numbers

    if isinstance(mask, (bool, np.bool_)) or not isinstance(mask, numbers.Integral) or int(mask) < 0:
        raise ArgumentTypeError(f"mask = {mask!r}: not a flag mask (a whole number >= 0, one element of a flags "
                                "array)")
    mask = int(mask)
    return [name for flag, name in FLAG_NAMES.items() if mask & flag]


def flag_where(condition, flag: Flag) -> np.ndarray:
    """A ``uint16`` mask array holding ``flag`` where ``condition`` is true, else 0.

    Parameters
    ----------
    condition : array_like of bool
        Where to set the flag. [-]
    flag : Flag
        The flag to set. [-]
    """
    return np.where(np.asarray(condition), np.uint16(flag), np.uint16(0)).astype(np.uint16)


def outside(values, lo: float, hi: float, flag: Flag, rtol: float = 1e-9) -> np.ndarray:
    """Mask with ``flag`` where ``values`` lie outside ``[lo, hi]`` (with a relative slack).

    Parameters
    ----------
    values : array_like
        The values to check. [SI]
    lo, hi : float
        The valid range, inclusive. [SI]
    flag : Flag
        The flag to set outside it. [-]
    rtol : float, default 1e-9
        Slack relative to the larger bound, so round-off at the bounds is not flagged. [-]
    """
    values = np.asarray(values, dtype=float)
    slack = rtol * max(abs(lo), abs(hi), 1e-300)
    return flag_where((values < lo - slack) | (values > hi + slack), flag)
