"""Sliding-mode pressure control, eq. (5)–(12) with the signs corrected: one of the core's two laws.

The law (``law_smc`` in ``firmware/core/controller.c``, mode ``smc`` of the table), bit-exact in
:func:`law`; its gains; its two variants (:data:`VARIANTS`): ``model``, ours, the corrected
eq. (12) with the model term from the identified first-order model and the valves' lift-off
(``docs/controller.md``), and ``paper``, β·tanh(S/ε) alone, the law as the paper ran it ("all the
terms in A are difficult to estimate … we set β to a large value", §IV.A), which Fig. 13
measured; their documented designs, tuning candidates and description in results. The entry is
:data:`CONTROLLER`.

References
----------
[mpam-characterization], §IV, eq. (5)–(12); signs corrected in docs/controller.md.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from mckibben._kernels import kernel, register
from mckibben.control.first_order import FirstOrderModel
from mckibben.control.fixed import TERM_LIM, clamp, mulq16, tanh_q15
from mckibben.control.laws._spec import ControllerSpec, GainSpec, Params, with_supervisor_model
from mckibben.control.laws._table import MODES
from mckibben.control.layout import IP_BETA_Q8, IP_C_DREF, IP_C_E, IP_C_EPS, IP_C_KI, IP_C_P, IP_C_U0, IP_S_SAT
from mckibben.errors import unknown_name

#: SET_MODE id (``MCK_MODE_SMC``), the table's.
MODE = MODES["smc"]
#: The sliding-mode variants, chosen by ``law=``: ``model`` (ours) and ``paper``.
VARIANTS = ("model", "paper")

GAINS = (
    GainSpec("smc_beta", "beta", "PWM counts", 1e3, 0, 255_000, 120.0, "MCK_GAIN_SMC_BETA",
             "switching gain (the firmware's start-up value; the paper's 120)"),
    GainSpec("smc_eps", "eps", "Pa", 1.0, 1, 1_000_000, 20e3, "MCK_GAIN_SMC_EPS", "boundary layer of tanh(S/ε)"),
    GainSpec("smc_ki", "ki", "1/s", 1e3, 0, 1_000_000, 10.0, "MCK_GAIN_SMC_KI", "integral weight of S = e + Ki·I"),
    GainSpec("smc_tau", "tau", "s", 1e6, 0, 10_000_000, 0.09, "MCK_GAIN_SMC_TAU", "τ of the model term"),
    GainSpec("smc_g", "g", "Pa/count", 1e3, 0, 100_000_000, 3000.0, "MCK_GAIN_SMC_G",
             "G of the model term (0: no model term, the paper's law)"),
    GainSpec("smc_i_max", "i_max", "Pa s", 1e3, 0, 2_147_483_647, 1e4, "MCK_GAIN_SMC_IMAX", "clamp of the integral"),
    GainSpec("smc_u0", "u0", "PWM counts", 1e3, 0, 255_000, 0.0, "MCK_GAIN_SMC_U0", "valve lift-off of the model term"),
)
#: The documented designs, one per variant. Ours (``model``: with the model term carrying the
#: holding command a small β suffices; docs/control.md says how it was chosen) and the paper's
#: law (β·tanh(S/ε) alone, β = 150 the paper's faster setting; ε and Ki ours, chosen so that the
#: integral brings the β = 120 step to its target within Fig. 13's second).
DESIGNS = {"model": {"beta": 50.0, "eps": 100e3, "ki": 5.0, "i_max": 4e4},
           "paper": {"beta": 150.0, "eps": 50e3, "ki": 12.0, "i_max": 1e4}}
#: The candidate grids of the tuning: β [counts], ε [Pa], Ki [1/s] and (``model``) the model
#: term's τ as fractions of the identified one (down to the fast phase of a muscle file's plant).
GRID = {"model": {"beta": (10.0, 20.0, 50.0), "eps": (50e3, 100e3, 200e3, 400e3), "ki": (1.0, 2.5, 5.0),
                  "tau_factor": (1.0, 1 / 4, 1 / 16, 1 / 64, 1 / 256)},
        "paper": {"beta": (115.0, 120.0, 130.0, 150.0, 175.0, 200.0), "eps": (25e3, 50e3, 100e3, 200e3),
                  "ki": (4.0, 12.0, 24.0)}}


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def law(ip, p, dpref, e, isum):
    """Sliding-mode command for given state, without side effects (``law_smc``), bit-exact.

    Parameters
    ----------
    ip : numpy.ndarray
        iparams of one instance (:mod:`mckibben.control.layout`). [-]
    p : int
        Measured pressure. [Pa]
    dpref : int
        Reference increment over one period, p_ref,k - p_ref,k-1. [Pa]
    e : int
        Error p_ref - p. [Pa]
    isum : int
        Sum of the errors (the integral is isum * Ts), already updated and clamped. [Pa]

    Returns
    -------
    tuple of int
        The command u in PWM counts Q8 (256 = one count) and the surface S. [-], [Pa]
    """
    s = e + (mulq16(isum, ip[IP_C_KI]) >> 8)
    u = clamp(mulq16(p, ip[IP_C_P]), np.int64(-TERM_LIM), np.int64(TERM_LIM))
    u += clamp(mulq16(dpref, ip[IP_C_DREF]), np.int64(-TERM_LIM), np.int64(TERM_LIM))
    u += clamp(mulq16(e, ip[IP_C_E]), np.int64(-TERM_LIM), np.int64(TERM_LIM))
    sabs = -s if s < 0 else s
    if sabs >= ip[IP_S_SAT]:
        th = 32768
    else:
        th = tanh_q15(mulq16(sabs, ip[IP_C_EPS]))
    t4 = (ip[IP_BETA_Q8] * th) >> 15
    u = u - t4 if s < 0 else u + t4
    # the valves' lift-off: inverse of the dead zone, on the side the command opens
    if u > 0:
        return u + ip[IP_C_U0], s
    if u < 0:
        return u - ip[IP_C_U0], s
    return 0, s


def from_gains(model: FirstOrderModel, beta: float, eps: float, ki: float, *, i_max: float = 1e4,
           base: Params) -> Params:
    """Core parameters of the sliding-mode law from an identified model and the design gains.

    The model term of the law (``docs/controller.md``) uses τ, G and the lift-off u0 of the
    identified first-order model; β, ε and Ki are the design's. The PID gains and supervisor
    settings are taken from ``base``.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model (G in Pa per PWM count, τ); G = 0 for no model term. [-]
    beta : float
        Switching gain. [PWM counts]
    eps : float
        Boundary-layer width. [Pa]
    ki : float
        Integral weight of the surface. [1/s]
    i_max : float, default 1e4
        Clamp of the error integral. [Pa s]
    base : CoreParams
        Source of every other parameter. [-]

    Returns
    -------
    CoreParams
        With ``mode`` the sliding mode's.

    References
    ----------
    [mpam-characterization], eq. (5), (8), (12); signs corrected in docs/controller.md.
    """
    if model.gain > 0:
        base = with_supervisor_model(base, model)
    return replace(base, beta=float(beta), eps=float(eps), ki=float(ki), tau=float(model.tau),
                   g=float(model.gain), u0=float(model.lift_off), i_max=float(i_max), mode=MODE)


def variant_params(model: FirstOrderModel, beta: float | None = None, *, law: str = "model",
                   eps: float | None = None, ki: float | None = None, base: Params) -> Params:
    """Sliding-mode core parameters of one variant with its documented design.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model (the ``model`` variant's model term; the supervisor's valve model). [-]
    beta : float, optional
        Switching gain; default the variant's design (:data:`DESIGNS`: 50 for ``model``, 150,
        the paper's faster setting, for ``paper``). [PWM counts]
    law : {"model", "paper"}, default "model"
        ``model``: u = v + u0·sign(v), v = (p + τ(ṗ_ref + Ki·e))/G + β·tanh(S/ε);
        ``paper``: u = β·tanh(S/ε) (the core with G = 0). [-]
    eps : float, optional
        Boundary layer; default the variant's design. [Pa]
    ki : float, optional
        Surface integral weight; default the variant's design. [1/s]
    base : CoreParams
        Supervisor and other settings. [-]

    Returns
    -------
    CoreParams
        With ``mode`` the sliding mode's; ``g = 0`` for the ``paper`` variant.
    """
    if law not in VARIANTS:
        raise unknown_name("sliding-mode law", law, VARIANTS)
    tuning = DESIGNS[law]
    beta = tuning["beta"] if beta is None else beta
    eps = tuning["eps"] if eps is None else eps
    ki = tuning["ki"] if ki is None else ki
    if law == "paper":
        base = with_supervisor_model(base, model) if model.gain > 0 else base  # the supervisor keeps it
        model = FirstOrderModel(gain=0.0, tau=0.0)  # G = 0: no model term (nor lift-off)
    return from_gains(model, beta, eps, ki, i_max=tuning["i_max"], base=base)


def design(model: FirstOrderModel, base: Params, *, law: str = "model", beta: float | None = None,
           eps: float | None = None, ki: float | None = None, lam: float | None = None) -> Params:
    """The sliding mode's design (registry ``smc``): :func:`variant_params` (``lam`` is the PID's, unused).

    Parameters
    ----------
    model : FirstOrderModel
        Identified model. [-]
    base : CoreParams
        Supervisor settings. [-]
    law : {"model", "paper"}, default "model"
        Sliding-mode variant. [-]
    beta, eps, ki : float, optional
        Gains to hold instead of the documented design. [PWM counts, Pa, 1/s]
    lam : float, optional
        Ignored. [s]
    """
    return variant_params(model, beta, law=law, eps=eps, ki=ki, base=base)


def candidates(model: FirstOrderModel, base: Params, top: float, grid: dict, *, law: str = "model",
               beta=None, eps=None, ki=None, lam=None):
    """The sliding mode's tuning candidates (registry ``smc``): β, ε, Ki and the model term's τ.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model. [-]
    base : CoreParams
        Supervisor settings. [-]
    top : float
        Top pressure of the design steps (unused). [Pa]
    grid : dict
        The candidate grid of the variant (:data:`GRID`). [-]
    law : {"model", "paper"}, default "model"
        Sliding-mode variant. [-]
    beta, eps, ki : float, optional
        Gains held instead of tuned. [PWM counts, Pa, 1/s]
    lam : float, optional
        Ignored. [s]

    Returns
    -------
    tuple of list
        The candidates' free gains and their core parameters. [-]
    """
    given = {"beta": beta, "eps": eps, "ki": ki}
    axes = [(v,) if given[k] is not None else grid[k] for k, v in given.items()]
    axes.append(grid.get("tau_factor", (1.0,)))
    cands = [dict(zip(("beta_counts", "eps_Pa", "ki_per_s", "tau_s"), (*map(float, c[:3]), c[3] * model.tau)))
             for c in itertools.product(*axes)]
    ps = [variant_params(replace(model, tau=c["tau_s"]), c["beta_counts"], law=law, eps=c["eps_Pa"],
                         ki=c["ki_per_s"], base=base) for c in cands]
    if law == "paper":  # no model term: τ plays no part
        cands = [{k: v for k, v in c.items() if k != "tau_s"} for c in cands]
    return cands, ps


def describe(p: Params) -> dict:
    """The sliding mode's gains as reported in results.

    Parameters
    ----------
    p : CoreParams
        Core parameters. [-]
    """
    return {"law": "paper" if p.g == 0 else "model", "beta_counts": p.beta, "eps_Pa": p.eps,
            "ki_per_s": p.ki, "tau_s": p.tau, "g_Pa_per_count": p.g, "lift_off_counts": p.u0}


CONTROLLER = ControllerSpec(
    name="smc", c_name="SMC", label="SMC\n(ours)",
    summary="sliding mode, eq. (5)-(12) with the signs corrected; law 'model' (model term) or 'paper'",
    gains=GAINS, law=law, design=design, candidates=candidates, describe=describe,
    designs=DESIGNS, grid=GRID, variants=VARIANTS, extension=False,
    references="[mpam-characterization] §IV eq. (5)-(12); docs/controller.md",
)

register(__name__)  # the kernel above compiles once the package loads Numba (mckibben._kernels)
