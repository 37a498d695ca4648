"""Direction-aware force laws: a registered law F(P, L) with hysteresis inside it.

A static law gives one force per (pressure, length); a muscle gives two, a lower one while it
inflates and a higher one while it deflates (the braid's and the sleeve's friction). Its
*direction-aware form* feeds the law through one play (backlash) operator of threshold r on the
pressure, z = play_r[P] (z_k = max(P_k − r, min(P_k + r, z_{k−1})), rate independent: only the
order of the pressures counts), in one of two structures (:data:`STRUCTURES`):

- ``"play"`` (a Hammerstein form): F = law(θ, z, L). The law sees a pressure that lags the
  supplied one by r while inflating and leads it by r while deflating, so the loop is
  2r·∂F/∂P wide: wide where the muscle is stiff in pressure, closed where it is slack.
- ``"friction"`` (Tondu & Lopez 2000, their dry-friction term, proportional to
  pressure, with the sign of the pressure's change): F = law(θ, P, L) + A_f·P·(z − P)/r, A_f a
  friction area [m²]. The factor (z − P)/r runs from −1 (inflating) to +1 (deflating) across a
  reversal, over 2r of pressure, instead of jumping: the loop is 2·A_f·P wide.

Both are a plain function of the state (the play's output z, one number per muscle): the state
after a sequence is its last z, and :func:`branch_state` gives the state far along a branch
(z = P − r inflating, P + r deflating), the steady value a ``direction`` alone implies. The
operator's parameters (r, and A_f) are shared by every length and muscle the law is fitted on
(:func:`mckibben.fit.direction.fit_direction_aware`); the law's own parameters are its fit
spec's, read, never copied.

References
----------
Tondu & Lopez (2000): a dry-friction force proportional to pressure, opposing the motion (the
form only; its equation number was not checked against the paper's text here). Kuhnen (2003) for the play operator and its Hammerstein composition with a
static map (:mod:`mckibben.models.hysteresis.prandtl_ishlinskii`).
"""

from __future__ import annotations

import numpy as np

from mckibben.errors import InputError, unknown_name
from mckibben.models.hysteresis.prandtl_ishlinskii import play_matrix

__all__ = ["DEFAULT_STRUCTURE", "DIRECTIONS", "FRICTION_FORCE_NAME", "FRICTION_NAME", "PLAY_NAME", "STRUCTURES",
           "branch_force", "branch_state", "direction_aware_force", "play_pressure"]

#: The friction area A_f's name among a fitted law's parameters (and in a muscle file). [m²] (= N/Pa)
FRICTION_NAME = "friction_area_m2"
#: The friction's constant part F_0's name (a Coulomb force beside A_f·P; :func:`branch_force`). [N]
FRICTION_FORCE_NAME = "friction_force_N"
#: The play's threshold r's name among a fitted law's parameters (and, for the ``"play"`` structure, in a
#: muscle file). [Pa]
PLAY_NAME = "play_threshold_Pa"
#: The direction-aware structures: name -> its extra parameters (names with units), one line.
STRUCTURES = {
    "play": ((PLAY_NAME,), "law(z, L), z = play of threshold r on the pressure (Hammerstein)"),
    "friction": ((PLAY_NAME, FRICTION_NAME), "law(P, L) + A_f·P·(z − P)/r (Tondu–Lopez friction)"),
}
#: The structure ``mckibben fit --direction-aware`` fits, chosen on held-out evidence
#: (docs/hysteresis.md, ``benchmarks/bench_hysteresis_gap.py``): best for the best model on every
#: point and on the settled ones (``--min-samples``), with and without the run drift. [-]
DEFAULT_STRUCTURE = "play"
#: The branch names of an isometric table and the sign of the pressure's change on each. [-]
DIRECTIONS = {"inflate": -1.0, "deflate": 1.0}


def _check_structure(structure: str) -> str:
    if structure not in STRUCTURES:
        raise unknown_name("direction-aware structure", structure, STRUCTURES)
    return structure


def _threshold(r) -> float:
    r = float(r)
    if not (np.isfinite(r) and r > 0):
        raise InputError(f"play_threshold_Pa: {r!r} must be a finite pressure > 0 [Pa]")
    return r


def play_pressure(pressure, threshold: float, state: float | None = None) -> tuple[np.ndarray, float]:
    """The play operator's output over one pressure sequence, and its final state.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure, in the order it was applied, shape (k,). [Pa]
    threshold : float
        The play's threshold r (> 0). [Pa]
    state : float, optional
        The play's output before the first sample; default ``pressure[0] + r``, the state of a
        muscle just deflated to its first pressure (the start of an inflate/deflate test). [Pa]

    Returns
    -------
    z : numpy.ndarray
        Play output per sample, shape (k,). [Pa]
    state : float
        Play output after the last sample, to continue the sequence. [Pa]

    References
    ----------
    Kuhnen (2003), the play operator (:func:`~mckibben.models.hysteresis.play_matrix`).
    """
    p = np.asarray(pressure, dtype=float).ravel()
    r = _threshold(threshold)
    if p.size == 0:
        return np.zeros(0), float("nan") if state is None else float(state)
    z0 = p[0] + r if state is None else float(state)
    z, zf = play_matrix(np.array([r]), p, np.array([z0]))
    return z[:, 0], float(zf[0])


def branch_state(pressure, direction, threshold: float) -> np.ndarray:
    """The play's output far along a branch: P − r inflating, P + r deflating.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    direction : str or array_like of str
        ``"inflate"`` or ``"deflate"`` per element (broadcast). [-]
    threshold : float
        The play's threshold r. [Pa]

    Returns
    -------
    numpy.ndarray
        Play output z, broadcast over ``pressure`` and ``direction``. [Pa]
    """
    r = _threshold(threshold)
    d = np.asarray(direction)
    bad = ~np.isin(d, list(DIRECTIONS))
    if np.any(bad):
        raise InputError(f"direction: {np.ravel(d[bad])[0]!r} is not one of {', '.join(DIRECTIONS)}")
    sign = np.where(d == "deflate", 1.0, -1.0)
    return np.asarray(pressure, dtype=float) + sign * r


def direction_aware_force(law_force, structure: str, values, pressure, length, z, *, friction_force: float = 0.0,
                          **law_inputs) -> np.ndarray:
    """A law's direction-aware force, given the play's output z (the state) at each point.

    The ``"friction"`` structure's friction is (F_0 + A_f·P)·(z − P)/r: a constant (Coulomb) part F_0
    (``friction_force``, default none) beside the part proportional to pressure.

    Parameters
    ----------
    law_force : callable
        ``law_force(law_values, pressure [Pa], length [m], **law_inputs) -> force [N]``: the law's
        NumPy face (a fit spec's ``force``). [-]
    structure : {"play", "friction"}
        See :data:`STRUCTURES`. [-]
    values : array_like
        The law's parameters followed by the structure's (:data:`STRUCTURES`): the play's
        threshold r [Pa], and for ``"friction"`` the friction area A_f [m²]. [SI]
    friction_force : float, default 0.0
        ``"friction"``: the friction's constant part F_0 (≥ 0). [N]
    pressure : array_like
        Gauge pressure supplied. [Pa]
    length : array_like
        Muscle length. [m]
    z : array_like
        The play's output at each point (:func:`play_pressure` over a sequence, or
        :func:`branch_state` for a direction). [Pa]
    law_inputs : dict
        Keyword arguments passed to ``law_force`` (``direction``, ``rest_length``). [-]

    Returns
    -------
    numpy.ndarray
        Force. [N]

    References
    ----------
    Module notes; Tondu & Lopez (2000) for ``"friction"`` (the form of their friction term).
    """
    extra = len(STRUCTURES[_check_structure(structure)][0])
    v = np.asarray(values, dtype=float)
    law_v, op = v[:-extra], v[-extra:]
    r = _threshold(op[0])
    p = np.asarray(pressure, dtype=float)
    z = np.asarray(z, dtype=float)
    if structure == "play":
        return np.asarray(law_force(law_v, z, length, **law_inputs), dtype=float)
    return (np.asarray(law_force(law_v, p, length, **law_inputs), dtype=float)
            + (float(friction_force) + op[1] * p) * np.clip((z - p) / r, -1, 1))


def branch_force(law_force, law_values, friction_area: float, pressure, length, branch, *, friction_force: float = 0.0,
                 play_threshold: float = 0.0, **law_inputs) -> np.ndarray:
    """A law's force far along a branch of its direction-aware form: the ``"friction"`` form's law ∓ (F_0 + A_f·P)
    (inflating −, deflating +), or the ``"play"`` form's law at z = P ∓ r.

    The structure (:func:`direction_aware_force`) at the play's branch state (:func:`branch_state`):
    the steady force of a muscle whose pressure has moved one way for a while (each step of an
    isotonic sweep, the braid slipping). The ``"friction"`` form's factor (z − P)/r is −1 inflating
    and +1 deflating there whatever the threshold r; the ``"play"`` form (``play_threshold`` r > 0)
    is the law at the play's output z = P − r inflating, P + r deflating. With ``branch`` None, the
    law alone (the middle of the loop).

    Parameters
    ----------
    law_force : callable
        ``law_force(law_values, pressure [Pa], length [m], **law_inputs) -> force [N]``. [-]
    law_values : array_like
        The law's parameters. [SI]
    friction_area : float
        A_f (≥ 0). [m²]
    pressure : array_like
        Gauge pressure. [Pa]
    length : array_like
        Muscle length. [m]
    branch : str, array_like of str, or None
        ``"inflate"`` or ``"deflate"`` per element (broadcast), or None. [-]
    friction_force : float, default 0.0
        The friction's constant part F_0 (≥ 0): the slip limit is F_0 + A_f·P, a Coulomb force
        beside the part proportional to pressure (the plant's Dahl limit has both). [N]
    play_threshold : float, default 0.0
        The ``"play"`` form's threshold r (> 0), or 0: no play. A law has one operator, so a play
        with a friction (``friction_area`` or ``friction_force`` above 0) is refused. [Pa]
    law_inputs : dict
        Passed to ``law_force`` (``direction`` for a law with a branch per direction). [-]

    Returns
    -------
    numpy.ndarray
        Force. [N]

    References
    ----------
    Tondu & Lopez (2000): a dry-friction force proportional to pressure, opposing the motion; Dahl
    (1968) for a slip limit with a constant part; Kuhnen (2003) for the play operator.
    """
    if branch is None:
        return np.asarray(law_force(np.asarray(law_values, dtype=float), pressure, length, **law_inputs), dtype=float)
    if play_threshold:
        if friction_area or friction_force:
            raise InputError(f"{PLAY_NAME}: a play ({play_threshold!r} Pa) and a friction ({FRICTION_NAME} "
                             f"{friction_area!r}, {FRICTION_FORCE_NAME} {friction_force!r}) together; a law has one "
                             "operator, give one of them")
        values = np.concatenate([np.asarray(law_values, dtype=float).ravel(), [_threshold(play_threshold)]])
        return direction_aware_force(law_force, "play", values, pressure, length,
                                     branch_state(pressure, branch, play_threshold), **law_inputs)
    r = 1.0  # any threshold: far along a branch (z − P)/r = ∓1 [Pa]
    values = np.concatenate([np.asarray(law_values, dtype=float).ravel(), [r, float(friction_area)]])
    return direction_aware_force(law_force, "friction", values, pressure, length,
                                 branch_state(pressure, branch, r), friction_force=friction_force, **law_inputs)
