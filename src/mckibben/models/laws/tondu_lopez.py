"""Tondu–Lopez with a pressure threshold: kernel, NumPy face, parameters, inverse and fit spec.

F = π·r0²·max(P − P_th, 0)·[a(1 − k·ε)² − b], ε = 1 − l/l0, a = 3/tan²α0, b = 1/sin²α0.

References
----------
Tondu, B., Lopez, P. (2000), Modeling and control of McKibben artificial muscle robot actuators,
IEEE Control Syst. Mag. 20(2), 15–38. doi:10.1109/37.833638, eq. (4). The threshold: [mpam-characterization] Fig. 10.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from mckibben._kernels import kernel, register

from mckibben.errors import check_array
from mckibben.models.flags import Flag, flag_where
from mckibben.models.laws._base import (NTH, THETA_MAX, THETA_MIN, THETA_STARTS_DEG, FitSpec, Law, evaluate_kernel,
                                        geometry_params, offset_flag)
from mckibben.models.laws.chou_hannaford import BRAID_ANGLE_PRIOR, ZERO_FACTOR

# θ: r0 [m], a = 3/tan²α0, b = 1/sin²α0, k [-], p_th [Pa], 1/l0 [1/m]
TL_R0, TL_A, TL_B, TL_K, TL_PTH, TL_IL0 = range(6)
#: r0 bounds as factors of the measured outer diameter. [-]
R0_FACTOR = (0.25, 1.0)
#: Contraction correction bounds. [-]
K_BOUNDS = (0.5, 5.0)
#: Log-normal prior on r0: median as a factor of the outer diameter [-] (the braid's radius at rest
#: is half its diameter, about the muscle's outer diameter) and the factor of one standard
#: deviation [-] (the strands' thickness and the tube's play: well within 1.5×).
R0_PRIOR = (0.5, 1.5)
#: Largest fitted pressure threshold, as a fraction of the highest measured pressure: the tube
#: takes pressure before the braid moves ([mpam-characterization] Fig. 10: tens of kPa on the
#: miniature muscle), a threshold past half the range would leave the law no data to pull on. [-]
PTH_FRACTION = 0.5


@kernel(error_model="numpy", inline="always")
def tondu_lopez(pressure, length, th, o, w):
    """Tondu–Lopez force with a pressure threshold. [N]

    F = π·r0²·max(P − P_th, 0)·[a(1 − k·ε)² − b], ε = 1 − l/l0, a = 3/tan²α0, b = 1/sin²α0.
    Tondu & Lopez (2000), eq. (4); the threshold: [mpam-characterization] Fig. 10.

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
    r0 = th[o + (TL_R0) * w]
    dp = pressure - th[o + (TL_PTH) * w]
    dp = dp if dp > 0.0 else 0.0
    q = 1.0 - th[o + (TL_K) * w] * (1.0 - length * th[o + (TL_IL0) * w])
    return math.pi * r0 * r0 * dp * (th[o + (TL_A) * w] * q * q - th[o + (TL_B) * w])


def tondu_lopez_theta(initial_radius, initial_angle, k=1.0, p_threshold=0.0, nominal_length=1.0) -> np.ndarray:
    """θ of :func:`tondu_lopez` (arrays broadcast to per-element columns).

    Parameters
    ----------
    initial_radius : array_like
        r0. [m]
    initial_angle : array_like
        α0, from the axis. [rad]
    k : array_like, default 1.0
        Contraction correction. [-]
    p_threshold : array_like, default 0.0
        Pressure below which the law pulls nothing. [Pa]
    nominal_length : array_like, default 1.0
        Rest length l0. [m]
    """
    r0, a0, k, pth, l0 = np.broadcast_arrays(*(check_array(v, n, finite=False) for v, n in
                                               zip((initial_radius, initial_angle, k, p_threshold, nominal_length),
                                                   ("initial_radius", "initial_angle", "k", "p_threshold",
                                                    "nominal_length"))))
    th = np.zeros((NTH,) + r0.shape)
    th[TL_R0], th[TL_A], th[TL_B] = r0, 3.0 / np.tan(a0) ** 2, 1.0 / np.sin(a0) ** 2
    th[TL_K], th[TL_PTH], th[TL_IL0] = k, pth, 1.0 / l0
    return th


def tondu_lopez_force(pressure, contraction, initial_radius, initial_angle, k=1.0):
    """Pulling force of the Tondu–Lopez model with its contraction correction.

    F = π·r0²·P·[a·(1 − k·ε)² − b], a = 3/tan²α0, b = 1/sin²α0, ε = (L0 − L)/L0.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    contraction : array_like
        Contraction ε = 1 − L/L0. [-]
    initial_radius : float
        Braid radius at rest, r0. [m]
    initial_angle : float
        Braid angle at rest, α0, from the axis. [rad]
    k : float or array_like, default 1.0
        Correction of the contraction (k = 1: the ideal model; k > 1 reaches zero force at a
        smaller contraction, as real muscles do). [-]

    Returns
    -------
    numpy.ndarray
        Force (0 at negative gauge pressure). [N]

    References
    ----------
    Tondu & Lopez (2000), eq. (4); NOTES.md.
    """
    eps = np.asarray(contraction, dtype=float)
    th = tondu_lopez_theta(initial_radius, initial_angle, k, 0.0, 1.0)
    if th.ndim > 1:  # per-element parameters: broadcast them with the inputs
        p, e, idx = np.broadcast_arrays(np.asarray(pressure, dtype=float), eps, np.arange(th[0].size).reshape(th.shape[1:]))
        return evaluate_kernel(tondu_lopez, "tondu-lopez", p, 1.0 - e, th.reshape(NTH, -1)[:, idx])
    return evaluate_kernel(tondu_lopez, "tondu-lopez", pressure, 1.0 - eps, th)


def tondu_lopez_contraction(pressure, force, initial_radius, initial_angle, k=1.0):
    """Contraction at which the Tondu–Lopez muscle pulls ``force``: the model's inverse.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure (> 0). [Pa]
    force : array_like
        Pulling force (the hanging load). [N]
    initial_radius, initial_angle, k
        As in :func:`tondu_lopez_force`. [m], [rad], [-]

    Returns
    -------
    contraction : numpy.ndarray
        ε = 1 − L/L0 (negative: the load stretches the muscle beyond its rest length). [-]
    flags : numpy.ndarray
        ``slack`` where the pressure is zero (the model has no stiffness then).

    References
    ----------
    Tondu & Lopez (2000), eq. (4) solved for ε.
    """
    p, f = np.broadcast_arrays(check_array(pressure, "pressure", finite=False),
                               check_array(force, "force", finite=False))
    initial_radius = check_array(initial_radius, "initial_radius", finite=False)
    initial_angle = check_array(initial_angle, "initial_angle", finite=False)
    k = check_array(k, "k", finite=False)
    a = 3.0 / np.tan(initial_angle) ** 2
    b = 1.0 / np.sin(initial_angle) ** 2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        q = (f / (np.pi * initial_radius**2 * p) + b) / a
        eps = (1.0 - np.sqrt(q)) / k
    bad = ~(p > 0) | ~(q >= 0)
    # a load that is no finite pull (NaN, infinite, pushing) or a result past the braid's range
    # (a contraction above 1, or a stretch the model cannot give): flagged, never a bare number
    odd = ~np.isfinite(f) | (f < 0) | ~np.isfinite(eps) | (eps > 1.0) | (eps < -1.0)
    return (np.where(bad, np.nan, eps),
            flag_where(bad, Flag.SLACK) | flag_where(odd & ~bad, Flag.LOAD_OUT_OF_RANGE))


@dataclass(frozen=True)
class TonduLopez:
    """A Tondu–Lopez muscle with a pressure threshold: the plant's calibrated law as a static model.

    F = π·r0²·max(P − P_th, 0)·[a(1 − k·ε)² − b], a = 3/tan²α0, b = 1/sin²α0, ε = 1 − l/l0.

    Attributes
    ----------
    initial_radius : float
        r0. [m]
    initial_angle : float
        α0, from the axis. [rad]
    k : float
        Contraction correction. [-]
    p_threshold : float
        Pressure the tube takes before the braid moves. [Pa]
    nominal_length : float
        Rest length l0. [m]
    citation : str
        Where the numbers come from.
    """

    initial_radius: float
    initial_angle: float
    k: float = 1.0
    p_threshold: float = 0.0
    nominal_length: float = 0.097
    citation: str = "Tondu & Lopez (2000), eq. (4)"

    def theta(self) -> np.ndarray:
        """Parameters of :func:`tondu_lopez`. [SI]"""
        return tondu_lopez_theta(self.initial_radius, self.initial_angle, self.k, self.p_threshold,
                                 self.nominal_length)

    def force(self, pressure, length):
        """Pulling force at a gauge pressure [Pa] and length [m] (the law's raw value). [N]"""
        return evaluate_kernel(tondu_lopez, "tondu-lopez", pressure, length, self.theta())

    def length_under_load(self, pressure, load):
        """Equilibrium length under a hanging load [N] at a gauge pressure [Pa]; NaN with ``slack``
        where the muscle pulls no load (P ≤ P_th). [m]"""
        eps, flags = tondu_lopez_contraction(np.asarray(pressure, dtype=float) - self.p_threshold, load,
                                             self.initial_radius, self.initial_angle, self.k)
        return self.nominal_length * (1.0 - eps), flags


def fit_spec(muscle, fmax: float, data=None) -> FitSpec:
    """Fit spec on isometric data: α0 (unless the muscle file gives the braid angle), r0, k, the pressure
    threshold P_th and the zero.

    Bounds: α0 in [1°, 54.7°) (beyond, the ideal braid pushes); r0 within [0.25, 1] × the outer
    diameter (an effective braid radius at rest); k in [0.5, 5]; the pressure threshold P_th within
    [0, :data:`PTH_FRACTION` × the highest measured pressure] (the pressure the tube takes before the
    braid moves, [mpam-characterization] Fig. 10: a force that starts late is a threshold, not a
    load-cell zero); the zero within ± :data:`~mckibben.models.laws.chou_hannaford.ZERO_FACTOR` × the
    peak force (a load cell's plausible zero error). A law saved before the threshold was fitted
    reads without it (``optional_names``) and has none.

    Priors (log-normal) from the muscle file's geometry: α0 about
    :data:`~mckibben.models.laws.chou_hannaford.BRAID_ANGLE_PRIOR` (unless known), r0 about
    :data:`R0_PRIOR` × the outer diameter.

    Parameters
    ----------
    muscle : MuscleSpec
        Nominal length and outer diameter (required), braid angle (optional). [-]
    fmax : float
        Largest |force| of the data. [N]
    data : mapping, optional
        ``pressure`` [Pa] sets the threshold's bound (0.6 MPa taken without it or without points). [-]

    References
    ----------
    Tondu & Lopez (2000), eq. (4); the threshold: [mpam-characterization] Fig. 10.
    """
    od, l0, alpha_known = geometry_params(muscle, "tondu-lopez")
    pressure = np.asarray(data["pressure"], dtype=float) if data is not None and "pressure" in data else np.zeros(0)
    n = pressure.size
    pmax = float(np.max(pressure)) if n else 0.6e6
    names, lo, hi = [], [], []
    priors = {}
    if alpha_known is None:
        names.append("alpha0_rad"), lo.append(THETA_MIN), hi.append(THETA_MAX - 1e-6)
        priors["alpha0_rad"] = BRAID_ANGLE_PRIOR
    names += ["r0_m", "k", "p_threshold_Pa", "offset_N"]
    lo += [R0_FACTOR[0] * od, K_BOUNDS[0], 0.0, -ZERO_FACTOR * fmax]
    hi += [R0_FACTOR[1] * od, K_BOUNDS[1], PTH_FRACTION * max(pmax, 1.0), ZERO_FACTOR * fmax]
    priors["r0_m"] = (R0_PRIOR[0] * od, R0_PRIOR[1])
    a_known = alpha_known is not None

    def force(v, pressure, length, direction=None, rest_length=None):
        # a law saved before the threshold was fitted has none (optional_names): its length says
        a0 = alpha_known if a_known else v[0]
        with_th = len(v) == (4 if a_known else 5)
        r0, k, off = v[-4 if with_th else -3], v[-3 if with_th else -2], v[-1]
        dp = np.maximum(np.asarray(pressure, dtype=float) - v[-2], 0.0) if with_th else pressure
        eps = 1.0 - np.asarray(length, dtype=float) / l0
        return tondu_lopez_force(dp, eps, r0, a0, k) + off

    starts = []
    for tdeg in (THETA_STARTS_DEG if alpha_known is None else (None,)):
        for th in ((0.05 * pmax, 0.4 * pmax) if n else (0.0,)):  # two threshold starts: the fit is not convex in it
            x = [] if a_known else [np.deg2rad(tdeg)]
            starts.append(np.array(x + [R0_PRIOR[0] * od, 1.0, th, 0.0]))
    return FitSpec(tuple(names), np.array(lo), np.array(hi), starts, force, lambda v: offset_flag(v[-1], fmax),
                   priors=priors)


def from_values(values: dict, muscle, direction: str = "inflate", valid_range: dict | None = None) -> TonduLopez:
    """The fitted values (by name, SI) as a :class:`TonduLopez` (the load cell's zero dropped).

    Parameters
    ----------
    values : dict
        ``alpha0_rad`` (unless the muscle gives ``braid_angle``), ``r0_m``, ``k``, ``p_threshold_Pa``
        (0 when absent: a law saved before the threshold was fitted). [SI]
    muscle : MuscleSpec
        The muscle the law was fitted for. [-]
    direction : str
        Unused (one branch). [-]
    valid_range : dict, optional
        Unused. [-]
    """
    return TonduLopez(float(values["r0_m"]), float(values.get("alpha0_rad", muscle.braid_angle)), float(values["k"]),
                      float(values.get("p_threshold_Pa", 0.0)), muscle.nominal_length,
                      citation=f"fitted: {muscle.path or muscle.id}")


def published(muscle) -> TonduLopez:
    """The Tondu–Lopez law of a catalogue muscle, from its construction (k = 1, no threshold).

    r0 is half the braid's mid-line diameter (outer diameter less one strand) and α0 its braid
    angle at rest (§II of the miniature muscle's paper, as :func:`~mckibben.models.geometry.miniature_geometry`).

    Parameters
    ----------
    muscle : MiniatureMuscle
        A catalogue muscle (``get_muscle("mpam97")``). [-]
    """
    g = muscle.geometry
    return TonduLopez(0.5 * (g.outer_diameter - g.strand_diameter), g.braid_angle, 1.0, 0.0, muscle.nominal_length)


LAW = Law(
    "tondu-lopez", tondu_lopez, "Tondu & Lopez (2000) eq. (4), with a pressure threshold",
    description="Tondu-Lopez with its contraction correction k, fitted alpha0, r0 and pressure threshold",
    params=TonduLopez, theta_of=lambda m, direction="elongation": m.theta(), fit_spec=fit_spec,
    from_values=from_values, needs=("nominal_length", "outer_diameter"), published=published,
    extra={"optional_names": ("p_threshold_Pa",)},
    c_rows={"TL_R0": TL_R0, "TL_A": TL_A, "TL_B": TL_B, "TL_K": TL_K, "TL_PTH": TL_PTH, "TL_IL0": TL_IL0},
    # the plant's calibrated columns: radius and braid angle at rest, k, threshold pressure
    plant_theta=lambda col, muscle: tondu_lopez_theta(col["r0"], col["alpha0"], col["k_tl"], col["p_threshold"],
                                                      col["nominal_length"]),
)


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
