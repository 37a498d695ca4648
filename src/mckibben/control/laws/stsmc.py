"""Super-twisting (second-order) sliding-mode pressure control: an extension law of the core.

The law (``firmware/core/law_stsmc.h``, mode 4), bit-exact, with its coefficients, its float64
reference, its design and its tuning candidates. With the sliding variable σ = e = p_ref − p
(relative degree one in the valve command) it is Levant's super-twisting algorithm on top of the
identified model's static inverse:

```
u   = p_ref/G + k1·√(min(|e|/φ, 8))·sign(e) + v          [PWM counts]
v  ← clamp(v + k2·Ts·sign(e), ±255 counts)               (explicit Euler)
out = u + u0·sign(u)                                      (inverse of the valves' dead zone)
```

The square root comes from a 129-entry table over ``|e|/φ`` ∈ [0, 8) with linear interpolation,
which makes the law linear for ``|e| < φ/16`` (where the ADC's 1 kPa steps would otherwise make
the root's infinite slope chatter), saturated beyond 8φ. The integral v, clamped to the valves'
range, learns what the model's inverse misses, so the law needs no sliding-surface integral and
no model of τ. G = 0 switches the feed-forward off (and u0 with it).

References
----------
[levant1993] A. Levant, "Sliding order and sliding accuracy in sliding mode control", Int. J. Control 58(6),
1993, doi:10.1080/00207179308923053 (the super-twisting algorithm).
J. A. Moreno and M. Osorio, "Strict Lyapunov functions for the super-twisting algorithm", IEEE
Trans. Automatic Control 57(4), 2012, doi:10.1109/TAC.2012.2186179 (gain conditions).
[seeber2025] R. Seeber and B. Andritsch, "Proper implicit discretization of the super-twisting controller —
without and with actuator saturation", Automatica 173, 112027, 2025,
doi:10.1016/j.automatica.2024.112027 (conditioning the integral against the actuator's limits).
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from mckibben._kernels import kernel, register
from mckibben.control.first_order import FirstOrderModel
from mckibben.control.fixed import clamp, mulq16, rdiv
from mckibben.control.laws._spec import ControllerSpec, GainSpec, Params
from mckibben.control.laws._table import MODES

#: SET_MODE id (``MCK_MODE_STSMC``), the table's.
MODE = MODES["stsmc"]
GAINS = (
    GainSpec("stsmc_k1", "st_k1", "PWM counts", 1e3, 0, 255_000, 10.0, "MCK_GAIN_STSMC_K1", "gain of the root term"),
    GainSpec("stsmc_k2", "st_k2", "counts/s", 1.0, 0, 1_000_000, 20.0, "MCK_GAIN_STSMC_K2", "gain of the integral term"),
    GainSpec("stsmc_phi", "st_phi", "Pa", 1.0, 1, 1_000_000, 50e3, "MCK_GAIN_STSMC_PHI", "error scale of the root"),
    GainSpec("stsmc_g", "st_g", "Pa/count", 1e3, 0, 100_000_000, 3000.0, "MCK_GAIN_STSMC_G",
             "G of the feed-forward (0: none)"),
    GainSpec("stsmc_u0", "st_u0", "PWM counts", 1e3, 0, 255_000, 0.0, "MCK_GAIN_STSMC_U0", "valve lift-off"),
)
#: The documented design: k1 [PWM counts], k2 [PWM counts/s], φ [Pa] (chosen by
#: :func:`mckibben.control.tuning.tune_gains` on the calibrated plant, docs/controller.md).
DESIGN = {"k1": 10.0, "k2": 20.0, "phi": 50e3}
#: The candidate grid of its tuning.
GRID = {"k1": (1.0, 2.0, 5.0, 10.0), "k2": (20.0, 100.0, 500.0), "phi": (20e3, 50e3, 100e3)}
#: Coefficients, in the order of the law's parameter slots (``mck_stsmc_coef_t``).
COEFS = ("c_g", "c_phi", "s_sat", "c_k2", "c_u0", "k1_q8")
#: Integer state slots: v, the integral term [counts Q16].
N_STATE = 1
#: Clamp of v: the valves' range [counts Q16].
V_MAX = 255 << 16
#: √8 in Q14, rounded: the saturated root.
SQRT8_Q14 = 46341


def sqrt_table() -> np.ndarray:
    """The square-root table of the law: ``round(sqrt(i/16) · 2^14)``, i = 0..128.

    Returns
    -------
    numpy.ndarray
        129 ``int64`` values; entry i is √x at x = i/16 in Q14. [-]
    """
    return np.rint(np.sqrt(np.arange(129) / 16.0) * 16384.0).astype(np.int64)


_SQRT = sqrt_table()


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def sqrt_q14(x_q12):
    """√x of x (Q12, 0 <= x < 8) in Q14 by linear interpolation in the table (``mck_sqrt_q14``). [-]"""
    i = x_q12 >> 8
    f = x_q12 & 0xFF
    a = _SQRT[i]
    return a + (((_SQRT[i + 1] - a) * f) >> 8)


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def law(st, ip, so, io, p, pref, e):
    """One step of the law (``mck_stsmc_law``), bit-exact.

    Parameters
    ----------
    st, ip : numpy.ndarray of int64
        istate and iparams of one instance. [-]
    so, io : int
        The law's first istate and iparams slot (:data:`mckibben.control.registry.LAYOUT`). [-]
    p : int
        Measured pressure (unused: the law acts on the error). [Pa]
    pref : int
        Clamped reference. [Pa]
    e : int
        Error p_ref − p. [Pa]

    Returns
    -------
    tuple of int
        The command in PWM counts Q8 and the surface reported (e). [-], [Pa]
    """
    eabs = -e if e < 0 else e
    u = mulq16(pref, ip[io])
    if eabs >= ip[io + 2]:
        sq = SQRT8_Q14
    else:
        sq = sqrt_q14(mulq16(eabs, ip[io + 1]))
    t = (ip[io + 5] * sq) >> 14
    u += (-t if e < 0 else t) + (st[so] >> 8)
    if e > 0:
        st[so] = clamp(st[so] + ip[io + 3], np.int64(-V_MAX), np.int64(V_MAX))
    if e < 0:
        st[so] = clamp(st[so] - ip[io + 3], np.int64(-V_MAX), np.int64(V_MAX))
    if u > 0:
        return u + ip[io + 4], e
    if u < 0:
        return u - ip[io + 4], e
    return 0, e


def derive(gains, ts_us) -> dict:
    """The law's coefficients from its SET_GAIN values (``mck_stsmc_derive``), exact in int64.

    Parameters
    ----------
    gains : mapping of str to array_like of int
        CoreParams field -> values in the SET_GAIN scale (``st_k1`` … ``st_u0``). [-]
    ts_us : array_like of int
        Control period. [us]

    Returns
    -------
    dict of str to numpy.ndarray
        :data:`COEFS` -> int64 values. [-]
    """
    g = {k: np.asarray(v, dtype=np.int64) for k, v in gains.items()}
    ts = np.asarray(ts_us, dtype=np.int64)
    gg = g["st_g"]
    c = {
        "c_g": np.where(gg != 0, np.minimum(rdiv(1000 << 24, np.where(gg != 0, gg, 1)), 1 << 24), 0),
        "c_phi": (1 << 28) // g["st_phi"],
        "s_sat": 8 * g["st_phi"],
        "c_k2": np.minimum(rdiv((g["st_k2"] * ts) << 16, 1_000_000), 1 << 24),
        "c_u0": rdiv(g["st_u0"] * 256, 1000),
        "k1_q8": rdiv(g["st_k1"] * 256, 1000),
    }
    return {k: np.asarray(v, dtype=np.int64) for k, v in c.items()}


def float_law(params: Params, p_ref, e, v):
    """The law in float64, for measuring the fixed-point error.

    Parameters
    ----------
    params : CoreParams
        Core parameters (``st_*``). [SI]
    p_ref : array_like
        Reference. [Pa]
    e : array_like
        Error p_ref − p. [Pa]
    v : array_like
        The integral term. [PWM counts]

    Returns
    -------
    numpy.ndarray
        The signed command before rounding and saturation. [PWM counts]
    """
    p_ref, e, v = (np.asarray(x, dtype=float) for x in (p_ref, e, v))
    ff = p_ref / params.st_g if params.st_g > 0 else 0.0
    u = ff + params.st_k1 * np.sqrt(np.minimum(np.abs(e) / params.st_phi, 8.0)) * np.sign(e) + v
    return u + (params.st_u0 * np.sign(u) if params.st_g > 0 else 0.0)


def design(model: FirstOrderModel, base: Params, *, law=None, beta=None, eps=None, ki=None, lam=None,
           k1: float | None = None, k2: float | None = None, phi: float | None = None) -> Params:
    """The super-twisting law on an identified model with the documented design (registry ``stsmc``).

    The feed-forward takes G and the lift-off u0 of the model; k1, k2 and φ are the design's.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model (G [Pa/count], lift-off [counts]). [-]
    base : CoreParams
        Supervisor settings. [-]
    law, beta, eps, ki, lam : optional
        The other controllers' design arguments, ignored. [-]
    k1 : float, optional
        Gain of the root term. [PWM counts]
    k2 : float, optional
        Gain of the integral term. [PWM counts/s]
    phi : float, optional
        Error scale of the root. [Pa]

    Returns
    -------
    CoreParams
        With ``mode = 4`` and the supervisor's valve model from ``model``.
    """
    d = DESIGN
    return replace(base, st_k1=float(d["k1"] if k1 is None else k1), st_k2=float(d["k2"] if k2 is None else k2),
                   st_phi=float(d["phi"] if phi is None else phi), st_g=float(model.gain),
                   st_u0=float(model.lift_off), sup_g=float(model.gain), sup_u0=float(model.lift_off),
                   mode=MODE)


def candidates(model: FirstOrderModel, base: Params, top: float, grid: dict, *, law=None, beta=None, eps=None,
               ki=None, lam=None):
    """The tuning candidates (registry ``stsmc``): every k1, k2, φ of the grid.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model. [-]
    base : CoreParams
        Supervisor settings. [-]
    top : float
        Top pressure of the design steps (unused). [Pa]
    grid : dict
        ``k1``, ``k2``, ``phi`` -> candidate values. [counts, counts/s, Pa]
    law, beta, eps, ki, lam : optional
        Ignored. [-]

    Returns
    -------
    tuple of list
        The candidates' free gains and their core parameters. [-]
    """
    cands = [{"k1_counts": float(a), "k2_counts_per_s": float(b), "phi_Pa": float(c)}
             for a, b, c in itertools.product(grid["k1"], grid["k2"], grid["phi"])]
    params = [design(model, base, k1=c["k1_counts"], k2=c["k2_counts_per_s"], phi=c["phi_Pa"]) for c in cands]
    return cands, params


def describe(params: Params) -> dict:
    """The gains as reported in results.

    Parameters
    ----------
    params : CoreParams
        Core parameters. [-]
    """
    return {"k1_counts": params.st_k1, "k2_counts_per_s": params.st_k2, "phi_Pa": params.st_phi,
            "g_Pa_per_count": params.st_g, "lift_off_counts": params.st_u0}


CONTROLLER = ControllerSpec(
    name="stsmc", c_name="STSMC", label="super-\ntwisting",
    summary="super-twisting (second-order) sliding mode on the model's static inverse",
    gains=GAINS, law=law, design=design, candidates=candidates, describe=describe,
    designs={"stsmc": DESIGN}, grid={"stsmc": GRID},
    state=N_STATE, coefs=COEFS, derive=derive, float_law=float_law,
    references="Levant 1993; Moreno & Osorio 2012; Seeber & Andritsch 2025 (mckibben.control.laws.stsmc)",
)

register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
