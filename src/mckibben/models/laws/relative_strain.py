"""A family law: force from pressure and relative strain, with an end-fitting length (length effects).

Muscles cut from one braided sleeve share a law in *relative* contraction, once the length the end
fittings take is set aside. With rest length L0 and an end-fitting length le that does not
contract, the braided part contracts by

    ε = (L0 − L)/(L0 − le),

and the pull is

    F = max(a1·x + a2·x² − (c0 + c1·x)·ε, 0),   x = P / 1 MPa,

a blocked force a1·x + a2·x² that falls linearly with contraction at a pressure-dependent rate.
In the muscle's own contraction k = (L0 − L)/L0 the maximum contraction is then
k_max(L0) = ε_max·(1 − le/L0): short muscles contract less, which is the length effect Hunt,
Graber-Tilton and Quinn measured on Festo muscles cut to several lengths (their k_max rises from
0.149 to 0.175 with rest length) and modelled as a force map in k/k_max. Here the same effect is
one parameter, le, fitted across the muscles of a family table (it is not identifiable from one
rest length: fitted on one muscle, le is 0 and the law is a plain force map in its contraction).

The coefficients take pressure in MPa (conditioning of the fit); the kernel converts. The law
pulls only (0 where it would push: a slack muscle); the load cell's zero ``offset_N`` is fitted
and dropped from the muscle's law.

References
----------
Hunt, A. J., Graber-Tilton, A., Quinn, R. D. (2017), Modeling length effects of braided pneumatic
actuators, ASME IDETC/CIE 2017, paper V05AT08A008 (the length effect: maximum strain depends on
rest length; force as a function of relative strain).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from mckibben._kernels import kernel, register

from mckibben.errors import InputError
from mckibben.models.laws._base import MPA, NTH, FitSpec, Law, evaluate_kernel, offset_flag

# θ: a1 [N/Pa], a2 [N/Pa²], c0 [N], c1 [N/Pa], L0 [m], le [m]
RS_A1, RS_A2, RS_C0, RS_C1, RS_L0, RS_LE = range(6)
NAME = "relative-strain"
#: Largest end-fitting length, as a fraction of the shortest rest length in the data. [-]
END_FRACTION = 0.5
OPTIONAL = ("end_length_m",)
#: Every parameter, the optional end length included, in order.
FULL_NAMES = ("a1_N_per_MPa", "a2_N_per_MPa2", "c0_N", "c1_N_per_MPa", "end_length_m", "offset_N")


@kernel(error_model="numpy", inline="always")
def relative_strain(pressure, length, th, o, w):
    """F = max(a1·P + a2·P² − (c0 + c1·P)·ε, 0), ε = (L0 − L)/(L0 − le). [N]

    Hunt, Graber-Tilton & Quinn (2017): force in relative strain, the length effect as an
    end-fitting length le.

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
    l0 = th[o + RS_L0 * w]
    eps = (l0 - length) / (l0 - th[o + RS_LE * w])
    p = pressure
    f = (th[o + RS_A1 * w] + th[o + RS_A2 * w] * p) * p - (th[o + RS_C0 * w] + th[o + RS_C1 * w] * p) * eps
    return f if f > 0.0 else 0.0


@dataclass(frozen=True)
class RelativeStrain:
    """The relative-strain law of one muscle of a family: the family's coefficients and its rest length.

    Attributes
    ----------
    a1 : float
        Blocked force per MPa. [N/MPa]
    a2 : float
        Blocked force per MPa². [N/MPa²]
    c0 : float
        Loss of force per unit relative strain at 0 Pa. [N]
    c1 : float
        Loss of force per unit relative strain, per MPa. [N/MPa]
    end_length : float
        Length of the end fittings (does not contract), le. [m]
    rest_length : float
        The muscle's rest length L0. [m]
    citation : str
        Where the numbers come from.
    """

    a1: float
    a2: float
    c0: float
    c1: float
    end_length: float
    rest_length: float
    citation: str = "mckibben's family law after the length effect of Hunt et al. (2017) [hunt2017]"

    def __post_init__(self):
        if not (self.rest_length > 0 and 0 <= self.end_length < self.rest_length):
            raise InputError(f"relative-strain law: need rest length > 0 and 0 <= end length < rest length; got "
                             f"{self.rest_length!r} m, {self.end_length!r} m")

    def theta(self) -> np.ndarray:
        """Parameters of :func:`relative_strain`. [SI]"""
        th = np.zeros(NTH)
        th[RS_A1], th[RS_A2] = self.a1 / MPA, self.a2 / MPA**2
        th[RS_C0], th[RS_C1] = self.c0, self.c1 / MPA
        th[RS_L0], th[RS_LE] = self.rest_length, self.end_length
        return th

    def force(self, pressure, length):
        """Pull at gauge pressures [Pa] and lengths [m]. [N]"""
        return evaluate_kernel(relative_strain, NAME, pressure, length, self.theta())


def _force(v, names, pressure, length, rest_length):
    """The law with the load cell's zero, from a value vector in ``names`` order. [N]"""
    d = dict(zip(names, v))
    p = np.asarray(pressure, dtype=float) / MPA
    l0 = np.asarray(rest_length, dtype=float)
    eps = (l0 - np.asarray(length, dtype=float)) / (l0 - d.get("end_length_m", 0.0))
    f = (d["a1_N_per_MPa"] + d["a2_N_per_MPa2"] * p) * p - (d["c0_N"] + d["c1_N_per_MPa"] * p) * eps
    return np.maximum(f, 0.0) + d["offset_N"]


def fit_spec(muscle, fmax: float, data=None) -> FitSpec:
    """Fit spec: a1, a2, c0, c1, the end length (two rest lengths or more in the data) and the zero.

    Bounds: a1 ≥ 0 (a muscle pulls harder inflated), c0 ≥ 0 (and loses pull as it contracts),
    0 ≤ le ≤ 0.5 × the shortest rest length, the zero within ± the peak force. The starts come from
    a linear least-squares fit of the pulling rows (the law is linear in a and c for a given le),
    for le at 0 and at 10 % of the shortest rest length.

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
    names = ("a1_N_per_MPa", "a2_N_per_MPa2", "c0_N", "c1_N_per_MPa") + (("end_length_m",) if family else ()) \
        + ("offset_N",)
    le_max = END_FRACTION * float(rest.min())
    lo = np.array([0.0, -np.inf, 0.0, -np.inf] + ([0.0] if family else []) + [-fmax])
    hi = np.array([np.inf] * 4 + ([le_max] if family else []) + [fmax])

    def force(v, pressure, length, direction=None, rest_length=None):
        rl = muscle.nominal_length if rest_length is None else rest_length
        # a saved family law carries the end length whatever data the spec was built on: its length says
        nm = names if len(v) == len(names) else tuple(n for n in FULL_NAMES if len(v) == 6 or n not in OPTIONAL)
        return _force(v, nm, pressure, length, rl)

    starts = []
    if n:
        p = np.asarray(data["pressure"], dtype=float) / MPA
        ell = np.asarray(data["held_length"], dtype=float)
        f = np.asarray(data["force"], dtype=float)
        pull = f > 0.05 * fmax
        for frac in ((0.0, 0.1) if family else (0.0,)):
            le = frac * float(rest.min())
            eps = (rest - ell) / (rest - le)
            x = np.column_stack([p, p * p, -eps, -eps * p, np.ones_like(p)])[pull]
            if x.shape[0] >= x.shape[1]:
                c = np.linalg.lstsq(x, f[pull], rcond=None)[0]
            else:
                c = np.array([fmax, 0.0, 0.0, 0.0, 0.0])
            start = [max(c[0], 1e-3), c[1], max(c[2], 0.0), c[3]] + ([le] if family else []) + [c[4]]
            starts.append(np.clip(np.array(start, dtype=float), lo, hi))
    else:
        starts.append(np.array([fmax, 0.0, 0.0, 0.0] + [0.0] * family + [0.0]))

    def physical(v):
        d = dict(zip(names, v))
        out = offset_flag(d["offset_N"], fmax)
        pmax = float(np.max(data["pressure"])) / MPA if n else 1.0
        if d["c0_N"] + min(d["c1_N_per_MPa"] * pmax, 0.0) < 0:
            out.append("negative_stiffness")  # the muscle would pull more as it contracts
        return out

    return FitSpec(names, lo, hi, starts, force, physical)


def from_values(values: dict, muscle, direction: str = "inflate", valid_range: dict | None = None) -> RelativeStrain:
    """The fitted values (by name, SI) as the law of the muscle of rest length ``muscle.nominal_length``.

    Parameters
    ----------
    values : dict
        ``a1_N_per_MPa``, ``a2_N_per_MPa2``, ``c0_N``, ``c1_N_per_MPa`` and, for a family fit,
        ``end_length_m``. [SI, pressure in MPa]
    muscle : MuscleSpec
        The muscle: its nominal length is the rest length the law is evaluated for. [-]
    direction : str
        Unused (one branch). [-]
    valid_range : dict, optional
        Unused. [-]
    """
    return RelativeStrain(float(values["a1_N_per_MPa"]), float(values["a2_N_per_MPa2"]), float(values["c0_N"]),
                          float(values["c1_N_per_MPa"]), float(values.get("end_length_m", 0.0)),
                          float(muscle.nominal_length), citation=f"fitted: {muscle.path or muscle.id}")


LAW = Law(
    NAME, relative_strain, "mckibben's form, after the length effect of Hunt et al. (2017) [hunt2017] (not their equation)",
    description="family law: blocked force and its fall with relative strain, an end-fitting length across rest lengths",
    params=RelativeStrain, theta_of=lambda m, direction="elongation": m.theta(), fit_spec=fit_spec,
    from_values=from_values, needs=("nominal_length",), family=True, extra={"optional_names": OPTIONAL},
    c_rows={"RS_A1": RS_A1, "RS_A2": RS_A2, "RS_C0": RS_C0, "RS_C1": RS_C1, "RS_L0": RS_L0, "RS_LE": RS_LE},
)


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
