"""The length-effect model of Festo muscles by Hunt, Graber-Tilton and Quinn, solved for the force.

Hunt, Graber-Tilton and Quinn model a braided pneumatic actuator (Festo DMSP) by the pressure it
needs to pull a force F at a contraction ε = (L0 − L)/L0,

    P = c0 + c1·tan(c2·(ε/(c4·F + ε_max) + c3)) + c5·F + c6·S,

where ε_max is the muscle's largest contraction (free, at the largest pressure): the length effect
enters through ε_max, which depends on the muscle's rest length (0.149 for a 153 mm muscle to 0.175
for a 281 mm one, as the authors' lab code lists their measurements), and the force shortens the
stroke (c4 < 0). S is 0 while the muscle contracts and 1 while it extends (the hysteresis).

Here the model is solved for F at given P and L (as the authors' own code does, numerically): the
right-hand side rises with F wherever the muscle is contracted (ε ≥ 0, c1, c2, c5 > 0, c4 ≤ 0), so
the root is unique and bisection finds it to round-off. At ε = 0 the force is the limit from the
contracted side: no more than the pole F = ε_max/(−c4), where the stroke vanishes (above ~615 kPa
with the published constants the formula at ε = 0 alone would give a little more: the model is
discontinuous there). For a muscle stretched beyond its rest length (ε < 0, outside the model's
range) the force is held at its value at ε = 0 (the model's tangent there is near-vertical at high
pressure, so a tangent would extrapolate wildly). The law pulls only: where the root is negative
(below the pressure that holds the free muscle at that contraction) the muscle is slack and the law
gives 0, as a load cell on a slack muscle reads.

Published constants (Festo DMSP-10, 0–620 kPa): c0 = 254.3 kPa, c1 = 192 kPa, c2 = 2.0265,
c3 = −0.461, c4 = −0.331·10⁻³ N⁻¹, c5 = 1.23 kPa/N, c6 = 15.6 kPa
(:data:`mckibben.datasets.published.HUNT_QUINN_SETS`).

References
----------
Hunt, A. J., Graber-Tilton, A., Quinn, R. D. (2017), Modeling length effects of braided pneumatic
actuators, Proc. ASME IDETC/CIE 2017, paper V05AT08A008 (as the authors' lab code cites it). The
equation and the constants as implemented by the authors' lab (Agile and Adaptive Robotics Lab,
Portland State University; MATLAB ``inverse_BPA_model``); the paper's equation number could not be
checked (no copy of its text was available to us).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from mckibben._kernels import kernel, register

from mckibben.errors import InputError
from mckibben.models.laws._base import NTH, FitSpec, Law, evaluate_kernel

# θ: c0 [Pa], c1 [Pa], c2 [-], c3 [-], c4 [1/N], c5 [Pa/N], c6·S [Pa], ε_max [-], 1/L0 [1/m], the solve's tolerance [-]
HQ_C0, HQ_C1, HQ_C2, HQ_C3, HQ_C4, HQ_C5, HQ_C6S, HQ_EMAX, HQ_IL0, HQ_TOL = range(10)
NAME = "hunt-quinn"
KPA = 1e3  # Pa per kPa
#: The force solve stops when its bracket is narrower than this × (1 N + |F|): round-off. Carried in θ
#: (row ``HQ_TOL``) so that the C face reads the same number. [-]
SOLVE_TOL = 1e-13
HALF_PI = 1.5707963267948966  # π/2, as the C face writes it (C99's <math.h> has no M_PI) [rad]
#: The tangent's argument must stay below π/2 by this much at ε = 0 (c2·|c3|): the model's range. [rad]
ARG_MARGIN = 1e-3


@kernel(error_model="numpy", inline="always")
def _excess(force, pressure, eps, th, o, w):
    """The model's pressure at a force, less the given pressure; ±inf outside the tangent's range. [Pa]"""
    den = th[o + HQ_C4 * w] * force + th[o + HQ_EMAX * w]
    if den <= 0.0:
        return math.inf  # a force beyond the model's: the stroke would be gone
    arg = th[o + HQ_C2 * w] * (eps / den + th[o + HQ_C3 * w])
    if arg >= HALF_PI:
        return math.inf
    if arg <= -HALF_PI:
        return -math.inf
    return (th[o + HQ_C0 * w] + th[o + HQ_C1 * w] * math.tan(arg) + th[o + HQ_C5 * w] * force
            + th[o + HQ_C6S * w] - pressure)


@kernel(error_model="numpy", inline="always")
def _solve(pressure, eps, th, o, w):
    """The force at which the model needs ``pressure`` at contraction ``eps`` ≥ 0 (bisection). [N]"""
    lo = -1.0
    k = 0
    while _excess(lo, pressure, eps, th, o, w) > 0.0 and k < 200:
        lo *= 2.0
        k += 1
    hi = 1.0
    k = 0
    while _excess(hi, pressure, eps, th, o, w) < 0.0 and k < 200:
        hi *= 2.0
        k += 1
    if not (_excess(lo, pressure, eps, th, o, w) <= 0.0 <= _excess(hi, pressure, eps, th, o, w)):
        return math.nan
    tol = th[o + HQ_TOL * w]
    while True:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi or hi - lo <= tol * (1.0 + abs(mid)):
            break
        if _excess(mid, pressure, eps, th, o, w) < 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@kernel(error_model="numpy", inline="always")
def hunt_quinn(pressure, length, th, o, w):
    """F solving P = c0 + c1·tan(c2·(ε/(c4·F + ε_max) + c3)) + c5·F + c6·S, ε = 1 − L/L0. [N]

    Hunt, Graber-Tilton & Quinn (2017); beyond the rest length (ε < 0) its value at ε = 0; 0 where
    the root is negative (slack).

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
    eps = 1.0 - length * th[o + HQ_IL0 * w]
    f = _solve(pressure, eps if eps > 0.0 else 0.0, th, o, w)
    return 0.0 if f < 0.0 else f  # slack below the model's threshold pressure: it pulls, never pushes


@dataclass(frozen=True)
class HuntQuinn:
    """The Hunt–Graber-Tilton–Quinn model of one muscle (constants in the paper's units).

    Attributes
    ----------
    c0 : float
        Pressure offset. [kPa]
    c1 : float
        Scale of the tangent term. [kPa]
    c2 : float
        Gain inside the tangent. [-]
    c3 : float
        Offset inside the tangent. [-]
    c4 : float
        Loss of stroke per newton of force (≤ 0). [1/N]
    c5 : float
        Pressure per newton of force. [kPa/N]
    c6 : float
        Extra pressure while the muscle extends (the hysteresis). [kPa]
    max_strain : float
        ε_max: the free muscle's contraction at the largest pressure (rises with rest length). [-]
    rest_length : float
        L0. [m]
    extending : bool
        S = 1 (the muscle extends) instead of S = 0 (it contracts). [-]
    citation : str
        Where the numbers come from.
    pressure_range : tuple of float, default (0, inf)
        Gauge pressures the constants were identified on (0–620 kPa for the published DMSP-10 set). [Pa]
    """

    c0: float
    c1: float
    c2: float
    c3: float
    c4: float
    c5: float
    c6: float
    max_strain: float
    rest_length: float
    extending: bool = False
    citation: str = "Hunt, Graber-Tilton & Quinn (2017), ASME IDETC V05AT08A008"
    pressure_range: tuple = (0.0, math.inf)

    def __post_init__(self):
        if not (self.rest_length > 0 and self.max_strain > 0 and self.c1 > 0 and self.c2 > 0 and self.c5 > 0
                and self.c4 <= 0 and abs(self.c2 * self.c3) < 0.5 * math.pi - ARG_MARGIN):
            raise InputError(f"{NAME} law: need rest length > 0, max strain > 0, c1, c2, c5 > 0, c4 <= 0 and "
                             f"|c2·c3| < π/2; got L0 {self.rest_length!r} m, ε_max {self.max_strain!r}, c1 "
                             f"{self.c1!r}, c2 {self.c2!r}, c3 {self.c3!r}, c4 {self.c4!r}, c5 {self.c5!r}")

    def theta(self) -> np.ndarray:
        """Parameters of :func:`hunt_quinn`. [SI]"""
        th = np.zeros(NTH)
        th[HQ_C0], th[HQ_C1], th[HQ_C2], th[HQ_C3] = self.c0 * KPA, self.c1 * KPA, self.c2, self.c3
        th[HQ_C4], th[HQ_C5] = self.c4, self.c5 * KPA
        th[HQ_C6S] = self.c6 * KPA if self.extending else 0.0
        th[HQ_EMAX], th[HQ_IL0], th[HQ_TOL] = self.max_strain, 1.0 / self.rest_length, SOLVE_TOL
        return th

    def to_dict(self) -> dict:
        """The constants in SI with unit-suffixed keys (``params show --json``). [SI]"""
        return {"c0_Pa": self.c0 * KPA, "c1_Pa": self.c1 * KPA, "c2": self.c2, "c3": self.c3, "c4_per_N": self.c4,
                "c5_Pa_per_N": self.c5 * KPA, "c6_Pa": self.c6 * KPA, "max_strain": self.max_strain,
                "rest_length_m": self.rest_length, "extending": self.extending, "citation": self.citation}

    def force(self, pressure, length):
        """Pull at gauge pressures [Pa] and lengths [m]. [N]"""
        return evaluate_kernel(hunt_quinn, NAME, pressure, length, self.theta())

    def pressure(self, force, length):
        """The model as published: the gauge pressure that pulls ``force`` [N] at ``length`` [m]. [Pa]

        P = c0 + c1·tan(c2·(ε/(c4·F + ε_max) + c3)) + c5·F + c6·S (NaN outside the tangent's range).
        """
        f, ell = np.broadcast_arrays(np.asarray(force, dtype=float), np.asarray(length, dtype=float))
        eps = np.maximum(1.0 - ell / self.rest_length, 0.0)  # held at ε = 0 beyond the rest length, as the force
        den = self.c4 * f + self.max_strain
        with np.errstate(divide="ignore", invalid="ignore"):
            arg = self.c2 * (eps / den + self.c3)
            p = (self.c0 + self.c1 * np.tan(arg) + self.c5 * f + (self.c6 if self.extending else 0.0)) * KPA
        return np.where((den > 0) & (np.abs(arg) < 0.5 * np.pi), p, np.nan)


#: Fitted parameter names, in order (c2 is held at the published value: with ε_max free, c2 only
#: rescales c4 and ε_max, so fitting both would leave one direction unidentified). No load-cell zero:
#: the model absorbs a constant force offset Δ exactly (F → F − Δ is c0 → c0 + c5·Δ,
#: ε_max → ε_max + c4·Δ), so a separate zero would be unidentified but for the slack rows, and an
#: isotonic fit would trade it against the smallest load.
NAMES = ("c0_kPa", "c1_kPa", "c3", "c4_per_N", "c5_kPa_per_N", "max_strain")
#: Published c2, held in fits (see :data:`NAMES`). [-]
C2_HELD = 2.0265
#: Bounds of ε_max in a fit. [-]
MAX_STRAIN_BOUNDS = (0.01, 0.6)


def _law_of(d, rest_length) -> HuntQuinn:
    return HuntQuinn(d["c0_kPa"], d["c1_kPa"], C2_HELD, d["c3"], d["c4_per_N"], d["c5_kPa_per_N"], 0.0,
                     d["max_strain"], rest_length, citation=d.get("citation", "fitted"))


def fit_spec(muscle, fmax: float, data=None) -> FitSpec:
    """Fit spec: c0, c1, c3, c4, c5 and ε_max (c2 held at the published 2.0265, c6 = 0; no load-cell zero, see :data:`NAMES`).

    Bounds: c1, c5 > 0 (pressure rises with contraction and with force), |c2·c3| < π/2 (the
    tangent's range at rest length), −1/F_max ≤ c4 ≤ 0 (force shortens the stroke), ε_max in
    :data:`MAX_STRAIN_BOUNDS`. Starts: the published constants, with ε_max at 0.15 and 0.3 (the
    stroke of a Festo muscle and twice it).

    Parameters
    ----------
    muscle : MuscleSpec
        The muscle (its nominal length is the rest length). [-]
    fmax : float
        Largest |force| of the data. [N]
    data : mapping, optional
        Unused. [-]
    """
    l0 = muscle.nominal_length
    c3_lim = (0.5 * math.pi - ARG_MARGIN) / C2_HELD
    lo = np.array([-np.inf, 1e-3, -c3_lim, -1.0 / fmax, 1e-6, MAX_STRAIN_BOUNDS[0]])
    hi = np.array([np.inf, np.inf, c3_lim, 0.0, np.inf, MAX_STRAIN_BOUNDS[1]])

    def force(v, pressure, length, direction=None, rest_length=None):
        d = dict(zip(NAMES, v))
        law = _law_of(d, l0 if rest_length is None else float(np.asarray(rest_length).flat[0]))
        return law.force(pressure, length)

    pub = (254.3, 192.0, -0.461, max(-0.331e-3, -0.9 / fmax), 1.23)
    starts = [np.clip(np.array(pub + (e,)), lo, hi) for e in (0.15, 0.3)]
    return FitSpec(NAMES, lo, hi, starts, force)


def from_values(values: dict, muscle, direction: str = "inflate", valid_range: dict | None = None) -> HuntQuinn:
    """The fitted values (by name, the paper's units) as the law of the muscle.

    Parameters
    ----------
    values : dict
        ``c0_kPa``, ``c1_kPa``, ``c3``, ``c4_per_N``, ``c5_kPa_per_N``, ``max_strain``. [kPa, N, -]
    muscle : MuscleSpec
        The muscle: its nominal length is the rest length. [-]
    direction : str
        Unused (the contracting branch, S = 0). [-]
    valid_range : dict, optional
        Unused. [-]
    """
    d = {k: float(values[k]) for k in NAMES}
    return _law_of(d | {"citation": f"fitted: {muscle.path or muscle.id}"}, float(muscle.nominal_length))


LAW = Law(
    NAME, hunt_quinn,
    "Hunt, Graber-Tilton & Quinn (2017), ASME IDETC V05AT08A008: P(ε, F) with a "
    "length-dependent maximum strain, solved for F",
    description="Festo length-effect model: pressure from strain relative to a rest-length-dependent stroke, "
                "solved for the force",
    params=HuntQuinn, theta_of=lambda m, direction="elongation": m.theta(), fit_spec=fit_spec,
    from_values=from_values, needs=("nominal_length",),
    c_rows={"HQ_C0": HQ_C0, "HQ_C1": HQ_C1, "HQ_C2": HQ_C2, "HQ_C3": HQ_C3, "HQ_C4": HQ_C4, "HQ_C5": HQ_C5,
            "HQ_C6S": HQ_C6S, "HQ_EMAX": HQ_EMAX, "HQ_IL0": HQ_IL0, "HQ_TOL": HQ_TOL},
)


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
