"""PID with a filtered derivative and conditional integration: one of the core's two laws.

The law (``law_pid`` in ``firmware/core/controller.c``, mode ``pid`` of the table), bit-exact in
:func:`law`; its gains; its design, lambda (IMC/SIMC) tuning on the identified first-order model
through the origin, the PID the paper found wanting (§IV.A), checked with python-control
(:func:`design_pid`); its tuning candidates and its description in results. The entry is
:data:`CONTROLLER`.

References
----------
[mpam-characterization], §IV.A. S. Skogestad, "Simple analytic rules for model reduction and PID
controller tuning", J. Process Control 13 (2003) 291–309, eq. (20)–(21).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from mckibben._kernels import kernel, register
from mckibben.control.first_order import FirstOrderModel
from mckibben.control.fixed import TERM_LIM, clamp, mulq16
from mckibben.control.laws._spec import ControllerSpec, GainSpec, Params
from mckibben.control.laws._table import MODES
from mckibben.control.layout import IP_ALPHA, IP_C_KD, IP_C_KIP, IP_C_KP, IS_DQ, IS_E_PREV, IS_IU
from mckibben.control.metrics import ONE_MINUS_INV_E, crossing_time
from mckibben.datasets.paper_points import FIG13
from mckibben.errors import InputError

#: SET_MODE id (``MCK_MODE_PID``), the table's.
MODE = MODES["pid"]
#: Where the paper's line through the origin meets the model: Fig. 13's step target, 0.55 MPa. [Pa]
OPERATING_POINT_PA = FIG13["target_Pa"]

GAINS = (
    GainSpec("pid_kp", "kp", "counts/Pa", 1e9, 0, 1_000_000_000, 1e-3, "MCK_GAIN_PID_KP", "proportional gain"),
    GainSpec("pid_ki", "ki_pid", "counts/(Pa s)", 1e9, 0, 2_147_483_647, 0.011, "MCK_GAIN_PID_KI", "integral gain"),
    GainSpec("pid_kd", "kd", "counts s/Pa", 1e12, 0, 2_147_483_647, 0.0, "MCK_GAIN_PID_KD", "derivative gain"),
    GainSpec("pid_tf", "tf", "s", 1e6, 0, 10_000_000, 0.005, "MCK_GAIN_PID_TF", "derivative filter time constant"),
)
#: The documented design: λ = τ/3 of the identified τ, three times faster than open loop, a usual
#: aggressive choice.
DESIGNS = {"pid": {"tau_over_lambda": 3.0}}
#: The candidate grid of the tuning: the design τ (fractions of the identified one) and λ
#: (multiples of that τ).
GRID = {"pid": {"tau_factor": (1.0, 1 / 4, 1 / 16, 1 / 64), "lam_factor": (1 / 4, 1 / 2, 1.0, 2.0, 4.0)}}


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def law(st, ip, e):
    """One step of the PID (``law_pid``), bit-exact.

    Parameters
    ----------
    st, ip : numpy.ndarray of int64
        istate and iparams of one instance (:mod:`mckibben.control.layout`). [-]
    e : int
        Error p_ref − p. [Pa]

    Returns
    -------
    int
        The command in PWM counts Q8. [-]
    """
    st[IS_DQ] += mulq16((e - st[IS_E_PREV]) * 16 - st[IS_DQ], ip[IP_ALPHA])
    st[IS_E_PREV] = e
    tp = clamp(mulq16(e, ip[IP_C_KP]), np.int64(-TERM_LIM), np.int64(TERM_LIM))
    td = clamp(mulq16(st[IS_DQ], ip[IP_C_KD]), np.int64(-TERM_LIM), np.int64(TERM_LIM))
    u = tp + td + (st[IS_IU] >> 8)
    ucnt = (u + 128) >> 8
    if not ((ucnt >= 255 and e > 0) or (ucnt <= -255 and e < 0)):
        inc = clamp(mulq16(e, ip[IP_C_KIP]), np.int64(-(1 << 25)), np.int64(1 << 25))
        st[IS_IU] = clamp(st[IS_IU] + inc, np.int64(-(1 << 24)), np.int64(1 << 24))
        u = tp + td + (st[IS_IU] >> 8)
    return u


@dataclass(frozen=True)
class PIDDesign:
    """A PID designed on a first-order model, with python-control's verdict on it.

    Parameters
    ----------
    kp : float
        Proportional gain. [counts/Pa]
    ki : float
        Integral gain. [counts/(Pa s)]
    kd : float
        Derivative gain. [counts s/Pa]
    tf : float
        Derivative filter time constant. [s]
    closed_loop_tau : float
        The λ the design aimed at (closed-loop time constant on the model). [s]
    gain_margin : float
        Gain margin of the loop on the model (inf if unbounded). [-]
    phase_margin_deg : float
        Phase margin of the loop on the model. [deg]
    predicted : dict
        ``control.step_info`` of the closed loop on the model (linear, no saturation). [s, %]
    """

    kp: float
    ki: float
    kd: float
    tf: float
    closed_loop_tau: float
    gain_margin: float
    phase_margin_deg: float
    predicted: dict


def design_pid(model: FirstOrderModel, closed_loop_tau: float, *, derivative: bool = False,
               ts: float = 1e-3, verdict: bool = True) -> PIDDesign:
    """Lambda (IMC / SIMC) tuning of a PI or PID on a first-order-plus-dead-time model.

    ``Kp = τ/(G(λ + θ))``, ``Ti = min(τ, 4(λ + θ))``, ``Ki = Kp/Ti``; with ``derivative`` a
    derivative cancelling half the dead time, ``Td = θ/2``, filtered with ``Tf = max(Td/10, Ts)``.
    python-control then checks the design: stability margins of the loop (dead time as a
    second-order Padé approximation) and the closed-loop step (``control.step_info``) on the
    linear model. Valve saturation and dead band are not in the model: that is exactly why a
    PID tuned this way degrades with step size and back pressure on the real plant (§IV.A).

    Parameters
    ----------
    model : FirstOrderModel
        Identified model, gain in Pa per PWM count. [-]
    closed_loop_tau : float
        Desired closed-loop time constant λ. [s]
    derivative : bool, default False
        Add the derivative term. [-]
    ts : float, default 1e-3
        Control period (lower bound of the filter time constant). [s]
    verdict : bool, default True
        Compute python-control's margins and predicted step (False: NaN and an empty dict, for
        screening many candidates). [-]

    Returns
    -------
    PIDDesign
        Gains in PWM counts per Pa and the verdict.

    References
    ----------
    S. Skogestad, "Simple analytic rules for model reduction and PID controller tuning",
    J. Process Control 13 (2003) 291–309, eq. (20)–(21) (SIMC).
    """
    if not (model.gain > 0 and model.tau > 0 and model.dead_time >= 0):
        raise InputError(f"design_pid: the model needs gain > 0 and tau > 0, got {model!r}")
    if not closed_loop_tau > 0:
        raise InputError(f"design_pid: closed_loop_tau={closed_loop_tau!r} must be > 0 s")
    lam, theta = float(closed_loop_tau), model.dead_time
    kp = model.tau / (model.gain * (lam + theta))
    ti = min(model.tau, 4.0 * (lam + theta))
    ki = kp / ti
    td = theta / 2.0 if derivative else 0.0
    kd = kp * td
    tf = max(td / 10.0, ts)
    if not verdict:
        return PIDDesign(kp, ki, kd, tf, lam, math.nan, math.nan, {})
    import control  # deferred: python-control costs ~0.8 s at import (only LTI objects need it)

    s = control.tf("s")
    c = kp + ki / s + kd * s / (tf * s + 1)
    loop = c * model.transfer_function(2)
    gm, pm, _, _ = control.margin(loop)
    cl = control.feedback(loop, 1)
    tgrid = np.linspace(0, 10 * (lam + theta + model.tau), 4000)
    info = control.step_info(cl, timepts=tgrid)
    predicted = {"time_constant_s": _tf_time_constant(cl, tgrid), "rise_time_s": info["RiseTime"],
                 "settling_time_s": info["SettlingTime"], "overshoot_pct": info["Overshoot"]}
    return PIDDesign(kp, ki, kd, tf, lam, float(gm), float(pm), predicted)


def _tf_time_constant(sys, tgrid) -> float:
    import control  # deferred: python-control costs ~0.8 s at import (only LTI objects need it)


    t, y = control.step_response(sys, tgrid)
    return crossing_time(t, y / sys.dcgain(), ONE_MINUS_INV_E)

def from_design(design: PIDDesign, *, base: Params) -> Params:
    """Core parameters of the PID mode from a :class:`PIDDesign`.

    Parameters
    ----------
    design : PIDDesign
        Designed gains. [-]
    base : CoreParams
        Source of every other parameter. [-]
    """
    return replace(base, kp=design.kp, ki_pid=design.ki, kd=design.kd, tf=design.tf, mode=MODE)


def default_pid(model: FirstOrderModel, closed_loop_tau: float | None = None,
                operating_point: float = OPERATING_POINT_PA) -> PIDDesign:
    """The PID the paper found wanting: lambda-tuned on a first-order model through the origin.

    The paper designed its PID on the first-order model of one voltage step (§IV.A), a line
    through the origin; here that line is the secant of the identified model at
    ``operating_point`` (:meth:`FirstOrderModel.through_origin`), exact there and wrong away
    from it, as the valves' lift-off makes it.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model. [-]
    closed_loop_tau : float, optional
        λ; default τ/3 (:data:`DESIGNS`). [s]
    operating_point : float, default 0.55e6
        Pressure at which the line through the origin meets the model. [Pa]

    Returns
    -------
    PIDDesign
        Gains in PWM counts per Pa and python-control's verdict on them.
    """
    lam = model.tau / DESIGNS["pid"]["tau_over_lambda"] if closed_loop_tau is None else closed_loop_tau
    return design_pid(model.through_origin(operating_point), lam)


def design(model: FirstOrderModel, base: Params, *, law: str | None = None, beta: float | None = None,
           eps: float | None = None, ki: float | None = None, lam: float | None = None) -> Params:
    """The PID's design (registry ``pid``): :func:`default_pid` on ``model`` (the sliding-mode gains unused).

    Parameters
    ----------
    model : FirstOrderModel
        Identified model. [-]
    base : CoreParams
        Supervisor settings. [-]
    law : str, optional
        Ignored. [-]
    beta, eps, ki : float, optional
        Ignored. [-]
    lam : float, optional
        Closed-loop time constant λ; default the documented design (τ/3). [s]
    """
    return from_design(default_pid(model, lam), base=base)


def candidates(model: FirstOrderModel, base: Params, top: float, grid: dict, *, law=None, beta=None,
               eps=None, ki=None, lam=None):
    """The PID's tuning candidates (registry ``pid``): the design τ and λ.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model. [-]
    base : CoreParams
        Supervisor settings. [-]
    top : float
        Top pressure of the design steps; the line through the origin is taken at half of it. [Pa]
    grid : dict
        The candidate grid (:data:`GRID`). [-]
    law, beta, eps, ki : optional
        Ignored. [-]
    lam : float, optional
        Closed-loop time constant held instead of tuned. [s]

    Returns
    -------
    tuple of list
        The candidates' free gains and their core parameters. [-]
    """
    op = 0.5 * top
    cands = [{"tau_s": f * model.tau, "lambda_s": float(lam) if lam is not None else g * f * model.tau}
             for f in grid["tau_factor"] for g in ((1.0,) if lam is not None else grid["lam_factor"])]
    ps = [from_design(design_pid(replace(model, tau=c["tau_s"]).through_origin(op), c["lambda_s"], verdict=False),
                 base=base) for c in cands]
    return cands, ps


def describe(p: Params) -> dict:
    """The PID's gains as reported in results.

    Parameters
    ----------
    p : CoreParams
        Core parameters. [-]
    """
    return {"kp_counts_per_Pa": p.kp, "ki_counts_per_Pa_s": p.ki_pid, "kd_counts_s_per_Pa": p.kd, "tf_s": p.tf}


CONTROLLER = ControllerSpec(
    name="pid", c_name="PID", label="PID",
    summary="PID with filtered derivative and conditional integration, lambda-tuned on the first-order model",
    gains=GAINS, law=law, design=design, candidates=candidates, describe=describe,
    designs=DESIGNS, grid=GRID, extension=False,
    references="[mpam-characterization] §IV.A; docs/controller.md",
)

register(__name__)  # the kernel above compiles once the package loads Numba (mckibben._kernels)
