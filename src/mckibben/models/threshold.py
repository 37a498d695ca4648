"""The threshold pressure: the gauge pressure a muscle takes before its braid carries load.

A braided muscle's braid is not taut at rest: the inner tube must first be inflated against its own
stiffness and the slack of the fibres taken up before the braid engages, so up to a threshold
pressure P_th the muscle pulls nothing of what its law predicts from that pressure. The force is
then the law's at the pressure above the threshold,

    F = F_law(max(P − P_th, 0), L),

a threshold P_th ≥ 0 [Pa]. Any registered force law without a threshold of its own may carry it as
an optional fitted term (:data:`THRESHOLD_NAME`, :func:`mckibben.fit.isometric.fit_points` with
``threshold=True``). Without it a law that pulls from the lowest pressure at its rest length (the
virtual-work law, whose elastic term sets a threshold only for a contracted muscle) buys a negative
load-cell zero to meet a map that reads 0 N there: the threshold *explains* that offset (a
pressure the muscle spends on itself) where the zero would *absorb* it (a sensor error on a tared
map). It is scored by the comparison on request only (it did not hold held out on the real
campaign: benchmarks/RESULTS.md): a muscle file does not store it, and saving a fit that carries it
is refused (:func:`mckibben.fit.muscle_file.muscle_file_text`).

Its bound is the one of Tondu–Lopez's own threshold
(:data:`~mckibben.models.laws.tondu_lopez.PTH_FRACTION` of the highest measured pressure, one
source): past half the range the law would be left no data to pull on.

References
----------
[wickramatunge2010] p. 193: the unstretched length is nearly flat at low pressure, "threshold-like
behavior ... strongly dominant in the PAM with short length and small diameter". Tondu & Lopez
(2000) eq. (4) with the threshold of [mpam-characterization] Fig. 10
(:mod:`mckibben.models.laws.tondu_lopez`): the same shift of pressure, written into that one law.
"""

from __future__ import annotations

import numpy as np

from mckibben.models.laws.tondu_lopez import PTH_FRACTION

__all__ = ["THRESHOLD_FRACTION", "THRESHOLD_NAME", "THRESHOLD_SUFFIX", "above_threshold", "split_threshold",
           "with_threshold"]

#: The threshold pressure's name among a fitted law's parameters (and in a muscle file). [Pa]
THRESHOLD_NAME = "threshold_pressure_Pa"
#: The suffix of a law's name when it carries the threshold (``virtual-work+threshold``): how a comparison
#: names the law with the term beside the law without it. [-]
THRESHOLD_SUFFIX = "+threshold"
#: The threshold's upper bound in a fit, as a fraction of the highest measured pressure (Tondu–Lopez's,
#: :data:`~mckibben.models.laws.tondu_lopez.PTH_FRACTION`). [-]
THRESHOLD_FRACTION = PTH_FRACTION


def above_threshold(pressure, threshold) -> np.ndarray:
    """The pressure the braid carries: max(P − P_th, 0).

    Parameters
    ----------
    pressure : array_like
        Gauge pressure P. [Pa]
    threshold : float or array_like
        Threshold pressure P_th (≥ 0). [Pa]

    Returns
    -------
    numpy.ndarray
        Pressure above the threshold, broadcast over the arguments; 0 at or below it. [Pa]

    References
    ----------
    [wickramatunge2010] p. 193; Tondu & Lopez (2000) eq. (4) with [mpam-characterization] Fig. 10 (module notes).
    """
    return np.maximum(np.asarray(pressure, dtype=float) - np.asarray(threshold, dtype=float), 0.0)


def split_threshold(model: str) -> tuple[str, bool]:
    """A model's name without :data:`THRESHOLD_SUFFIX`, and whether it had it.

    Parameters
    ----------
    model : str
        A force model's name, ``<law>`` or ``<law>+threshold``. [-]

    Returns
    -------
    (str, bool)
        The law's name and whether the threshold is fitted with it. [-]
    """
    if model.endswith(THRESHOLD_SUFFIX):
        return model[: -len(THRESHOLD_SUFFIX)], True
    return model, False


def with_threshold(law_force):
    """A law's force function evaluated above the threshold: its last value is P_th.

    Parameters
    ----------
    law_force : callable
        ``law_force(values, pressure [Pa], length [m], direction=None, rest_length=None) -> [N]`` (a
        fit spec's ``force``). [-]

    Returns
    -------
    callable
        ``force(values, pressure, length, direction=None, rest_length=None) -> [N]``, ``values`` the
        law's followed by P_th [Pa]: ``law_force(values[:-1], max(P − P_th, 0), …)``.
    """

    def force(values, pressure, length, direction=None, rest_length=None):
        v = np.asarray(values, dtype=float)
        return np.asarray(law_force(v[:-1], above_threshold(pressure, v[-1]), length, direction, rest_length),
                          dtype=float)

    return force
