"""The rig's components as Numba functions of one instance's state and parameter row.

State of one instance (``NS`` values): air mass in the chamber m [kg], inlet and bleed valve
openings x_in, x_bl [-], muscle length l [m], its rate v [m/s], braid friction force z [N].

Components (``docs/plant.md`` gives the parameters and why):

- supply: a regulated reservoir at ``supply_pressure`` with optional droop at high flow;
- valves: ISO 6358 flow through a sonic conductance C·x with critical pressure ratio b (choked
  below b, elliptic subsonic branch above, linearised in the last 0.1 % before equal pressures so
  the flow stays Lipschitz); opening x follows the coil current with a first-order lag; the coil
  current is the Arduino's PWM duty through the LM358 driver (gain, saturating at full current);
  below the dead band the valve stays shut;
- chamber: ideal gas, polytropic: p/ρⁿ constant for the gas in the chamber, so
  ṗ = (n/V)(R·T·ṁ − p·V̇) with T the gas temperature; volume = tubing dead volume + the tube lumen
  of the braid's diameter at the actual braid angle (eq. 2 gives θ from l); optional leak;
- muscle force: a named static law (calibrated Tondu–Lopez, Chou–Hannaford, or the empirical
  map of eq. 2+3 solved for the load), never pushing; passive tube stiffness beyond the rest
  length; braid friction as a Dahl element (rate-independent hysteresis: inflating needs more
  pressure than deflating);
- load: hanging mass over the pulley (gravity, damping), a blocked end, or a spring.

References
----------
ISO 6358-1:2013 (flow through pneumatic components); Tondu & Lopez (2000); Chou & Hannaford
(1996); 000_909f662a44080c85.txt eq. (2)–(3), §III–IV; Dahl, P. R. (1968), A solid friction model.
"""

from __future__ import annotations

import math

from numba import njit

from mckibben.plant import params as P

NS = 6
S_MASS, S_XIN, S_XBL, S_LEN, S_VEL, S_FRIC = range(NS)

# column indices, as module constants Numba can fold
I_SUPPLY = P.I_SUPPLY_PRESSURE
I_DROOP = P.I_SUPPLY_DROOP
I_CIN = P.I_VALVE_CONDUCTANCE
I_CBL = P.I_BLEED_CONDUCTANCE
I_B = P.I_CRITICAL_RATIO
I_TAUV = P.I_VALVE_TAU
I_DB = P.I_DEAD_BAND
I_DRV = P.I_DRIVER_GAIN
I_VDEAD = P.I_DEAD_VOLUME
I_CLEAK = P.I_LEAK_CONDUCTANCE
I_N = P.I_POLYTROPIC_N
I_T = P.I_TEMPERATURE
I_L0 = P.I_NOMINAL_LENGTH
I_LS = P.I_STRAND_LENGTH
I_K1 = P.I_K1
I_K2 = P.I_K2
I_OD = P.I_OUTER_DIAMETER
I_ID = P.I_INNER_DIAMETER
I_FM = P.I_FORCE_MODEL
I_R0 = P.I_R0
I_A0 = P.I_ALPHA0
I_KTL = P.I_K_TL
I_PTH = P.I_P_THRESHOLD
I_NCH = P.I_CH_TURNS
I_ELO = P.I_EMP_LOAD_LO
I_EHI = P.I_EMP_LOAD_HI
I_C3LO = P.I_EMP_C3_LO
I_C3HI = P.I_EMP_C3_HI
I_KP = P.I_PASSIVE_STIFFNESS
I_F0 = P.I_FRICTION_FORCE
I_F1 = P.I_FRICTION_PER_PA
I_SIG = P.I_FRICTION_STIFFNESS
I_LOAD = P.I_LOAD_KIND
I_LF = P.I_LOAD_FORCE
I_MASS = P.I_MOVING_MASS
I_DAMP = P.I_DAMPING
I_KS = P.I_SPRING_STIFFNESS
I_LFREE = P.I_SPRING_FREE_LENGTH
I_TLA = P.I_TL_A
I_TLB = P.I_TL_B
I_SIN0 = P.I_SIN0
I_RHOATM = P.I_RHO_ATM
I_INVTAU = P.I_INV_VALVE_TAU

P_ATM = P.P_ATM
R_AIR = P.R_AIR
T0 = P.T0
RHO0 = P.RHO0
GRAV = P.G
LAMINAR = 0.999  # pressure ratio above which the subsonic flow is linearised to zero


@njit(cache=True)
def iso6358_flow(c, p1, t1, p2, t2, b):
    """Signed mass flow from p1 to p2 through sonic conductance c (ISO 6358). [kg/s]

    Parameters: c [m³/(s·Pa)], p1, p2 absolute [Pa], t1, t2 upstream temperatures [K], b [-].
    """
    if c <= 0.0:
        return 0.0
    sign = 1.0
    if p2 > p1:
        p1, p2 = p2, p1
        t1 = t2
        sign = -1.0
    r = p2 / p1
    if r <= b:
        phi = 1.0
    elif r < LAMINAR:
        s = (r - b) / (1.0 - b)
        phi = math.sqrt(1.0 - s * s)
    else:
        s = (LAMINAR - b) / (1.0 - b)
        phi = math.sqrt(1.0 - s * s) * (1.0 - r) / (1.0 - LAMINAR)
    return sign * c * RHO0 * p1 * math.sqrt(T0 / t1) * phi


@njit(cache=True)
def valve_target(pwm, p):
    """Valve opening commanded by a PWM count through the driver and dead band. [-]"""
    duty = pwm / 255.0
    current = duty * p[I_DRV]
    if current > 1.0:
        current = 1.0
    db = p[I_DB]
    if current <= db:
        return 0.0
    return (current - db) / (1.0 - db)


@njit(cache=True)
def cos_theta_of(length, p):
    """cos θ of the braid from the length, eq. (2), kept inside (0.05, 0.9999). [-]"""
    c = (length - p[I_K2]) / (p[I_K1] * p[I_LS])
    if c < 0.05:
        c = 0.05
    if c > 0.9999:
        c = 0.9999
    return c


@njit(cache=True)
def chamber_volume(length, p):
    """Tubing dead volume plus the tube lumen at the braid's actual diameter. [m³]"""
    c = cos_theta_of(length, p)
    s = math.sqrt(1.0 - c * c)
    d = p[I_OD] * s / p[I_SIN0] - (p[I_OD] - p[I_ID])
    if d < 0.1 * p[I_ID]:
        d = 0.1 * p[I_ID]
    return p[I_VDEAD] + 0.25 * math.pi * d * d * length


@njit(cache=True)
def gauge_pressure(mass, length, p):
    """Gauge pressure of the chamber air (polytropic, p/ρⁿ fixed at the atmospheric state). [Pa]"""
    rho = mass / chamber_volume(length, p)
    return P_ATM * (rho / p[I_RHOATM]) ** p[I_N] - P_ATM


@njit(cache=True)
def muscle_force(pg, length, p):
    """Pulling force of the muscle at gauge pressure pg and length. [N] (never negative)"""
    model = int(p[I_FM])
    pos = pg if pg > 0.0 else 0.0
    if model == 0:  # Tondu–Lopez with a pressure threshold
        a = p[I_TLA]
        b = p[I_TLB]
        eps = 1.0 - length / p[I_L0]
        dp = pos - p[I_PTH]
        if dp < 0.0:
            dp = 0.0
        q = 1.0 - p[I_KTL] * eps
        f = math.pi * p[I_R0] * p[I_R0] * dp * (a * q * q - b)
    elif model == 1:  # Chou–Hannaford, strand b = Ls, n turns
        bs = p[I_LS]
        c = length / bs
        n = p[I_NCH]
        f = bs * bs * pos * (3.0 * c * c - 1.0) / (4.0 * math.pi * n * n)
    else:  # empirical map, eq. (2)+(3) solved for the load (linear in load)
        target = (length - p[I_K2]) / (p[I_K1] * p[I_LS])
        x = pos * 1e-6
        lo = ((p[I_C3LO] * x + p[I_C3LO + 1]) * x + p[I_C3LO + 2]) * x + p[I_C3LO + 3]
        hi = ((p[I_C3HI] * x + p[I_C3HI + 1]) * x + p[I_C3HI + 2]) * x + p[I_C3HI + 3]
        den = hi - lo
        if abs(den) < 1e-9:
            den = 1e-9 if den >= 0 else -1e-9
        f = p[I_ELO] + (p[I_EHI] - p[I_ELO]) * (target - lo) / den
    if f < 0.0:
        f = 0.0
    if length > p[I_L0]:
        f += p[I_KP] * (length - p[I_L0])
    return f


@njit(cache=True)
def derivatives(s, p, xin_t, xbl_t, out):
    """Time derivatives of one instance's state ``s`` into ``out``; returns the gauge pressure."""
    mass = s[S_MASS]
    length = s[S_LEN]
    v = s[S_VEL]
    z = s[S_FRIC]
    xin = s[S_XIN]
    xbl = s[S_XBL]
    vol = chamber_volume(length, p)
    t_gas_ref = p[I_T]
    rho = mass / vol
    p_abs = P_ATM * (rho / p[I_RHOATM]) ** p[I_N]
    t_gas = p_abs / (rho * R_AIR)
    pg = p_abs - P_ATM
    x_open = xin if xin > 0.0 else 0.0
    p_sup = P_ATM + p[I_SUPPLY] * (1.0 - p[I_DROOP] * x_open)
    b = p[I_B]
    q_in = iso6358_flow(p[I_CIN] * x_open, p_sup, t_gas_ref, p_abs, t_gas, b)
    q_bl = iso6358_flow(p[I_CBL] * (xbl if xbl > 0.0 else 0.0), p_abs, t_gas, P_ATM, t_gas_ref, b)
    q_lk = iso6358_flow(p[I_CLEAK], p_abs, t_gas, P_ATM, t_gas_ref, b)
    out[S_MASS] = q_in - q_bl - q_lk
    inv_tau = p[I_INVTAU]
    out[S_XIN] = (xin_t - xin) * inv_tau
    out[S_XBL] = (xbl_t - xbl) * inv_tau
    kind = int(p[I_LOAD])
    if kind == 1:  # blocked: the end does not move
        out[S_LEN] = 0.0
        out[S_VEL] = 0.0
        out[S_FRIC] = 0.0
        return pg
    fm = muscle_force(pg, length, p)
    out[S_FRIC] = 0.0  # the friction state is advanced exactly after each step (see rk4_step)
    if kind == 0:
        mass_moving = p[I_MASS] + p[I_LF] / GRAV
        f_ext = p[I_LF]
    else:
        mass_moving = p[I_MASS]
        f_ext = p[I_LF] - p[I_KS] * (length - p[I_LFREE])
    out[S_LEN] = v
    out[S_VEL] = (f_ext - fm - z - p[I_DAMP] * v) / mass_moving
    return pg


@njit(cache=True)
def rk4_step(s, p, xin_t, xbl_t, dt, k1, k2, k3, k4, tmp):
    """One step of size dt, in place: classical Runge–Kutta, then the exact Dahl friction update.

    The Dahl element ż = σ(v − |v|·z/F_c) is stiff when F_c is small and the end moves fast
    (a vented muscle stretched by its load: σ|v|/F_c ≈ 3·10⁴ 1/s, beyond RK4's stability at
    dt = 0.1 ms). It is split off: the Runge–Kutta stages hold z, and z is then advanced by the
    exact solution of the linear ODE for the step's mean velocity v̄ = Δl/dt,
    z ← F_c·sgn v̄ + (z − F_c·sgn v̄)·exp(−σ|v̄|dt/F_c), which is stable at any step.
    """
    derivatives(s, p, xin_t, xbl_t, k1)
    for j in range(NS):
        tmp[j] = s[j] + 0.5 * dt * k1[j]
    derivatives(tmp, p, xin_t, xbl_t, k2)
    for j in range(NS):
        tmp[j] = s[j] + 0.5 * dt * k2[j]
    derivatives(tmp, p, xin_t, xbl_t, k3)
    for j in range(NS):
        tmp[j] = s[j] + dt * k3[j]
    derivatives(tmp, p, xin_t, xbl_t, k4)
    length0 = s[S_LEN]
    for j in range(NS):
        s[j] += dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
    if int(p[I_LOAD]) == 1:
        return
    vbar = (s[S_LEN] - length0) / dt
    pg = gauge_pressure(s[S_MASS], s[S_LEN], p)
    fc = p[I_F0] + p[I_F1] * (pg if pg > 0.0 else 0.0)
    z_ss = fc if vbar >= 0.0 else -fc
    s[S_FRIC] = z_ss + (s[S_FRIC] - z_ss) * math.exp(-p[I_SIG] * abs(vbar) * dt / fc)


@njit(cache=True)
def static_length(pg, p):
    """Equilibrium length under the load at a fixed gauge pressure (bisection). [m]

    The force balance ignores friction (the middle of the hysteresis band).
    """
    kind = int(p[I_LOAD])
    l0 = p[I_L0]
    if kind == 1:
        return l0
    lo = 0.3 * l0
    hi = (p[I_K1] * p[I_LS] + p[I_K2]) * 0.999
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if kind == 0:
            f_ext = p[I_LF]
        else:
            f_ext = p[I_LF] - p[I_KS] * (mid - p[I_LFREE])
        if muscle_force(pg, mid, p) > f_ext:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


@njit(cache=True)
def mass_for_pressure(pg, length, p):
    """Air mass that gives gauge pressure pg at a length (inverse of :func:`gauge_pressure`). [kg]"""
    rho = p[I_RHOATM] * ((pg + P_ATM) / P_ATM) ** (1.0 / p[I_N])
    return rho * chamber_volume(length, p)
