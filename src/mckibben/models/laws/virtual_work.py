"""A law from virtual work: pressure on an effective area, less the sleeve's elastic force, less what the ends lose.

By virtual work a McKibben muscle pulls F = −P·dV/dL − dW/dL: the pressure on an *effective
area* −dV/dL (Chou & Hannaford 1996), less the force the bladder and braid store as elastic
energy when the muscle contracts (Klute & Hannaford 2000). Written in the muscle's own
contraction ε = (L0 − L)/L0 and x = P / 1 MPa, with the effective area linearised in contraction
and pressure (the braid narrows as it contracts; the bladder bulges under pressure) and an elastic
force that stiffens near the rest length and then grows linearly,

    F = s·max((a0 + a1·ε + a2·x)·x − g0·(1 − exp(−ε/e0)) − g1·ε, 0),
    s = 1 − (2λ/L0)·(1 − exp(−L0/(2λ))).

The elastic force g(ε) = g0·(1 − exp(−ε/e0)) + g1·ε rises from 0 at the rest length over a
contraction scale e0 to a plateau g0, then changes linearly (g1 of either sign: contracting stores
energy, g ≥ 0, which the fit checks over the measured contractions; a rubber tube's resistance to
inflation may level off or fall past its plateau). e0 carries a physical prior (:data:`E0_PRIOR`):
the held lengths of one muscle rarely resolve where the elastic force rises.

The elastic term is what sets the pressure threshold: a muscle held shorter than its rest length is
slack until the pressure force overcomes it (it pulls only above a threshold that rises with
contraction), while at the rest length (ε = 0) it pulls from the lowest pressure. For ε < 0 (a
muscle stretched beyond its rest length) the elastic term continues along its tangent at 0,
g = (g0/e0 + g1)·ε, so the law stays bounded in the plant.

**Length effect.** Muscles cut from one sleeve to different lengths differ by their ends: at each
end fitting the braid is held at the fitting's diameter and relaxes to the free muscle's over some
length, so near the ends it adds less force per unit of pressure than in the middle. Taking the
lost share at a distance z from the nearer fitting as exp(−z/λ) (a boundary layer of length λ)
and averaging it over the muscle gives the share s(L0) above: 1 − 2λ/L0 for a long muscle, and
always in (0, 1], falling smoothly for muscles only a few λ long (a share linear in 1/L0 would
reach zero at L0 = 2λ and extrapolate badly to short muscles). It is the length effect that Hunt,
Graber-Tilton and Quinn measured on Festo muscles cut to several lengths (force and contraction
depend on the rest length); λ is fitted only across rest lengths (on one muscle it is not
identifiable and is left out, s = 1).

The coefficients take pressure in MPa (conditioning of the fit); the kernel converts. The law pulls
only (0 where it would push); the load cell's zero ``offset_N`` is fitted and dropped from the
muscle's law. The saturating form of the elastic term is an empirical choice (two numbers, g0 and
e0), not a result of the papers.

References
----------
Chou, C.-P., Hannaford, B. (1996), Measurement and modeling of McKibben pneumatic artificial
muscles, IEEE Trans. Robotics and Automation 12(1) 90–102 (F = −P·dV/dL).
Klute, G. K., Hannaford, B. (2000), Accounting for elastic energy storage in McKibben artificial
muscle actuators, ASME J. Dyn. Syst. Meas. Control 122(2) 386–388; Klute, Czerniecki & Hannaford
(2002), Artificial muscles: actuators for biorobotic systems, Int. J. Robotics Research 21(4)
295–309 (the elastic force subtracted from the pressure force).
Hunt, A. J., Graber-Tilton, A., Quinn, R. D. (2017), Modeling length effects of braided pneumatic
actuators, ASME IDETC/CIE 2017, paper V05AT08A008 (force and contraction depend on rest length).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from mckibben._kernels import kernel, register

from mckibben.errors import InputError
from mckibben.models.laws._base import MPA, NTH, FitSpec, Law, evaluate_kernel, offset_flag

# θ: a0 [N/Pa], a1 [N/Pa], a2 [N/Pa²], g0 [N], e0 [-], g1 [N], L0 [m], λ [m]
VW_A0, VW_A1, VW_A2, VW_G0, VW_E0, VW_G1, VW_L0, VW_LAM = range(8)
NAME = "virtual-work"
#: Largest end-zone length λ, as a fraction of the shortest rest length in the data. [-]
END_FRACTION = 0.5
#: Bounds of the elastic term's strain scale e0. [-]
E0_BOUNDS = (1e-3, 0.5)
#: Log-normal prior on e0: median and the factor of one standard deviation. The elastic force is the
#: rubber's: a contraction ε widens the braid by a hoop strain cot²θ0·ε (Chou & Hannaford 1996,
#: D = D0·sinθ/sinθ0 at L = L0·cosθ/cosθ0), about 5–8·ε at the rest braid angles of 20–25° of
#: commercial sleeves, and a thin rubber tube's resistance to a hoop strain rises steeply and levels
#: off at hoop strains of order 0.1–0.2 (Klute & Hannaford 2000 store the rubber's energy in this
#: strain), so the contraction scale of its saturating part is e0 ≈ 0.15/cot²θ0 ≈ 0.02, known to a
#: factor of about 3. A physical order of magnitude, not a number fitted to any campaign: where the
#: held lengths resolve the rise (a contraction within a few e0) the data decide; where they do not
#: (one muscle held at contractions ≫ e0, whose elastic force is a step at the rest length for every
#: e0 below them) the prior holds e0 and the fit notes ``e0_from_prior``. [-]
E0_PRIOR = (0.02, 3.0)
#: Starting strain scales of the multi-start (the law is linear in the other parameters). [-]
E0_STARTS = (0.01, 0.03, 0.1)
OPTIONAL = ("end_zone_m",)
#: Every parameter, the optional end length included, in order.
FULL_NAMES = ("a0_N_per_MPa", "a1_N_per_MPa", "a2_N_per_MPa2", "g0_N", "e0", "g1_N", "end_zone_m", "offset_N")


@kernel(error_model="numpy", inline="always")
def virtual_work(pressure, length, th, o, w):
    """F = s·max((a0 + a1·ε + a2·P)·P − g0·(1 − exp(−ε/e0)) − g1·ε, 0), ε = 1 − L/L0, s(L0, λ) the ends' share. [N]

    Chou & Hannaford (1996) effective area, Klute & Hannaford (2000) elastic energy, Hunt,
    Graber-Tilton & Quinn (2017) length effect.

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
    l0 = th[o + VW_L0 * w]
    eps = (l0 - length) / l0
    e0 = th[o + VW_E0 * w]
    g0 = th[o + VW_G0 * w]
    if eps >= 0.0:
        g = g0 * (1.0 - math.exp(-eps / e0)) + th[o + VW_G1 * w] * eps
    else:  # stretched beyond the rest length: the tangent at 0, bounded
        g = (g0 / e0 + th[o + VW_G1 * w]) * eps
    p = pressure
    f = (th[o + VW_A0 * w] + th[o + VW_A1 * w] * eps + th[o + VW_A2 * w] * p) * p - g
    lam = th[o + VW_LAM * w]
    s = 1.0 + 2.0 * lam / l0 * math.expm1(-0.5 * l0 / lam) if lam > 0.0 else 1.0
    return s * f if f > 0.0 else 0.0


@dataclass(frozen=True)
class VirtualWork:
    """The virtual-work law of one muscle (of a family: the family's coefficients and its rest length).

    Attributes
    ----------
    a0 : float
        Effective area at rest, as force per MPa. [N/MPa]
    a1 : float
        Change of the effective area per unit contraction, as force per MPa. [N/MPa]
    a2 : float
        Change of the effective area with pressure, as force per MPa². [N/MPa²]
    g0 : float
        Saturating part of the elastic force. [N]
    e0 : float
        Its contraction scale. [-]
    g1 : float
        Linear part of the elastic force, per unit contraction. [N]
    end_zone : float
        Length λ over which the braid relaxes from an end fitting to the free muscle. [m]
    rest_length : float
        The muscle's rest length L0. [m]
    citation : str
        Where the numbers come from.
    """

    a0: float
    a1: float
    a2: float
    g0: float
    e0: float
    g1: float
    end_zone: float
    rest_length: float
    citation: str = "Chou & Hannaford (1996), Klute & Hannaford (2000), Hunt, Graber-Tilton & Quinn (2017)"

    def __post_init__(self):
        if not (self.rest_length > 0 and self.end_zone >= 0 and self.e0 > 0):
            raise InputError(f"virtual-work law: need rest length > 0, end zone >= 0 and e0 > 0; got "
                             f"{self.rest_length!r} m, {self.end_zone!r} m, e0 {self.e0!r}")

    def theta(self) -> np.ndarray:
        """Parameters of :func:`virtual_work`. [SI]"""
        th = np.zeros(NTH)
        th[VW_A0], th[VW_A1], th[VW_A2] = self.a0 / MPA, self.a1 / MPA, self.a2 / MPA**2
        th[VW_G0], th[VW_E0], th[VW_G1] = self.g0, self.e0, self.g1
        th[VW_L0], th[VW_LAM] = self.rest_length, self.end_zone
        return th

    def force(self, pressure, length):
        """Pull at gauge pressures [Pa] and lengths [m]. [N]"""
        return evaluate_kernel(virtual_work, NAME, pressure, length, self.theta())


def _terms(d, pressure, length, rest_length):
    """Contraction ε, pressure x [MPa], the unclipped pull and the ends' share s, from values by name."""
    x = np.asarray(pressure, dtype=float) / MPA
    l0 = np.asarray(rest_length, dtype=float)
    eps = (l0 - np.asarray(length, dtype=float)) / l0
    e0 = d["e0"]
    with np.errstate(over="ignore"):
        g = np.where(eps >= 0, d["g0_N"] * -np.expm1(-np.maximum(eps, 0.0) / e0) + d["g1_N"] * eps,
                     (d["g0_N"] / e0 + d["g1_N"]) * eps)
    f = (d["a0_N_per_MPa"] + d["a1_N_per_MPa"] * eps + d["a2_N_per_MPa2"] * x) * x - g
    return eps, x, f, ends_share(l0, d.get("end_zone_m", 0.0))


def ends_share(rest_length, end_zone):
    """The share of a muscle's length that pulls as a long one would: 1 − (2λ/L0)·(1 − exp(−L0/(2λ))). [-]

    Parameters
    ----------
    rest_length : array_like
        Rest length L0. [m]
    end_zone : float or array_like
        End-zone length λ (0: no ends, share 1). [m]
    """
    l0 = np.asarray(rest_length, dtype=float)
    lam = np.asarray(end_zone, dtype=float)
    safe = np.where(lam > 0, lam, 1.0)
    return np.where(lam > 0, 1.0 + 2.0 * safe / l0 * np.expm1(-0.5 * l0 / safe), 1.0)


def _force(v, names, pressure, length, rest_length):
    """The law with the load cell's zero, from a value vector in ``names`` order. [N]"""
    d = dict(zip(names, v))
    _, _, f, s = _terms(d, pressure, length, rest_length)
    return s * np.maximum(f, 0.0) + d["offset_N"]


def fit_spec(muscle, fmax: float, data=None) -> FitSpec:
    """Fit spec: a0, a1, a2, g0, e0, g1, the end zone λ (two rest lengths or more) and the load cell's zero.

    Bounds: a0 ≥ 0 (the muscle pulls when pressurised at its rest length), a1 ≤ 0 (the effective
    area shrinks as the braid contracts), g0 ≥ 0, g1 free (contracting stores elastic energy: the
    elastic force g(ε) ≥ 0, checked at the measured contractions by the physics check, flag
    ``negative_elastic_force``; a bound g1 ≥ 0 would ask more, an elastic force that never levels
    off), e0 in :data:`E0_BOUNDS` with the log-normal prior :data:`E0_PRIOR`, 0 ≤ λ ≤ 0.5 × the
    shortest rest length, the zero within ± the peak force. The starts come from a linear least-squares fit of the pulling rows (the law is linear in
    a0, a1, a2, g0, g1 for given e0 and λ), one per e0 of :data:`E0_STARTS` (and, across rest
    lengths, λ at 0 and at 10 % of the shortest rest length).

    Parameters
    ----------
    muscle : MuscleSpec
        The muscle (its nominal length is the rest length where the data have none). [-]
    fmax : float
        Largest |force| of the data. [N]
    data : mapping, optional
        ``pressure`` [Pa], ``held_length`` [m], ``force`` [N], ``rest_length`` [m]; None or
        empty: the names only. [-]
    """
    n = 0 if data is None else np.size(data["pressure"])
    rest = np.asarray(data["rest_length"], dtype=float) if n else np.full(1, muscle.nominal_length)
    family = n > 0 and np.unique(np.round(rest, 6)).size > 1
    names = tuple(nm for nm in FULL_NAMES if family or nm not in OPTIONAL)
    le_max = END_FRACTION * float(rest.min())
    bounds = {"a0_N_per_MPa": (0.0, np.inf), "a1_N_per_MPa": (-np.inf, 0.0), "a2_N_per_MPa2": (-np.inf, np.inf),
              "g0_N": (0.0, np.inf), "e0": E0_BOUNDS, "g1_N": (-np.inf, np.inf), "end_zone_m": (0.0, le_max),
              "offset_N": (-fmax, fmax)}
    lo = np.array([bounds[nm][0] for nm in names], dtype=float)
    hi = np.array([bounds[nm][1] for nm in names], dtype=float)

    def force(v, pressure, length, direction=None, rest_length=None):
        rl = muscle.nominal_length if rest_length is None else rest_length
        # a saved family law carries the end length whatever data the spec was built on: its length says
        nm = names if len(v) == len(names) else tuple(n for n in FULL_NAMES if len(v) == len(FULL_NAMES)
                                                      or n not in OPTIONAL)
        return _force(v, nm, pressure, length, rl)

    starts = []
    if n:
        x = np.asarray(data["pressure"], dtype=float) / MPA
        ell = np.asarray(data["held_length"], dtype=float)
        f = np.asarray(data["force"], dtype=float)
        pull = f > 0.05 * fmax
        eps = (rest - ell) / rest
        for le in ((0.0, 0.1 * float(rest.min())) if family else (0.0,)):
            s = ends_share(rest, le)
            for e0 in E0_STARTS:
                sat = -np.expm1(-np.maximum(eps, 0.0) / e0)
                cols = np.column_stack([s * x, s * eps * x, s * x * x, -s * sat, -s * eps, np.ones_like(x)])[pull]
                if cols.shape[0] >= cols.shape[1]:
                    c = np.linalg.lstsq(cols, f[pull], rcond=None)[0]
                else:
                    c = np.array([fmax, 0.0, 0.0, 0.0, 0.0, 0.0])
                vals = {"a0_N_per_MPa": c[0], "a1_N_per_MPa": c[1], "a2_N_per_MPa2": c[2], "g0_N": c[3], "e0": e0,
                        "g1_N": c[4], "end_zone_m": le, "offset_N": c[5]}
                starts.append(np.clip(np.array([vals[nm] for nm in names], dtype=float), lo, hi))
    else:
        vals = {"a0_N_per_MPa": fmax, "e0": E0_STARTS[0]}
        starts.append(np.array([vals.get(nm, 0.0) for nm in names], dtype=float))

    def physical(v):
        d = dict(zip(names, v))
        out = offset_flag(d["offset_N"], fmax)
        if n:  # the effective area must stay positive wherever the muscle was measured
            xmax = float(np.max(data["pressure"])) / MPA
            emax = float(np.max((rest - np.asarray(data["held_length"], dtype=float)) / rest))
            area = [d["a0_N_per_MPa"] + d["a1_N_per_MPa"] * e + d["a2_N_per_MPa2"] * xx
                    for e in (0.0, max(emax, 0.0)) for xx in (0.0, xmax)]
            if min(area) <= 0:
                out.append("negative_area")
            held = np.unique(np.maximum(eps, 0.0))
            if np.any(d["g0_N"] * -np.expm1(-held / d["e0"]) + d["g1_N"] * held < 0):
                out.append("negative_elastic_force")
        return out

    return FitSpec(names, lo, hi, starts, force, physical, priors={"e0": E0_PRIOR})


def from_values(values: dict, muscle, direction: str = "inflate", valid_range: dict | None = None) -> VirtualWork:
    """The fitted values (by name, SI) as the law of the muscle of rest length ``muscle.nominal_length``.

    Parameters
    ----------
    values : dict
        ``a0_N_per_MPa``, ``a1_N_per_MPa``, ``a2_N_per_MPa2``, ``g0_N``, ``e0``, ``g1_N`` and,
        for a family fit, ``end_zone_m``. [SI, pressure in MPa]
    muscle : MuscleSpec
        The muscle: its nominal length is the rest length the law is evaluated for. [-]
    direction : str
        Unused (one branch). [-]
    valid_range : dict, optional
        Unused. [-]
    """
    return VirtualWork(float(values["a0_N_per_MPa"]), float(values["a1_N_per_MPa"]), float(values["a2_N_per_MPa2"]),
                       float(values["g0_N"]), float(values["e0"]), float(values["g1_N"]),
                       float(values.get("end_zone_m", 0.0)), float(muscle.nominal_length),
                       citation=f"fitted: {muscle.path or muscle.id}")


LAW = Law(
    NAME, virtual_work,
    "Chou & Hannaford (1996) effective area; Klute & Hannaford (2000) elastic energy; Hunt, Graber-Tilton & Quinn "
    "(2017), ASME IDETC V05AT08A008, length effects",
    description="family law: pressure on an effective area less the sleeve's elastic force, what the end fittings "
                "cost across rest lengths",
    params=VirtualWork, theta_of=lambda m, direction="elongation": m.theta(), fit_spec=fit_spec,
    from_values=from_values, needs=("nominal_length",), family=True, extra={"optional_names": OPTIONAL},
    c_rows={"VW_A0": VW_A0, "VW_A1": VW_A1, "VW_A2": VW_A2, "VW_G0": VW_G0, "VW_E0": VW_E0, "VW_G1": VW_G1,
            "VW_L0": VW_L0, "VW_LAM": VW_LAM},
)


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
