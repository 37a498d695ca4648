"""The rig's physics for a block of instances: structure of arrays, instances innermost.

A *block* holds up to :data:`W` instances ("lanes") in one flat float64 array: its parameters
(rows of :class:`~mckibben.plant.packing.Col`), its force law's parameters
(:mod:`mckibben.models.laws`), its state with the four Runge–Kutta slopes and a scratch area, each
row W lanes long (:data:`OFF_P`, :data:`OFF_TH`, :data:`OFF_ST`, :data:`OFF_SC`). Every function
here loops over the lanes innermost with no branch the compiler cannot turn into a select, and
addresses every row at a compile-time offset from the one base pointer: LLVM then proves the
rows independent without run-time alias checks and vectorizes each loop across instances (with
2-D arrays whose strides are run-time values it did not; ``docs/plant.md``).

State of one lane (``NS`` rows): absolute chamber pressure p [Pa], gas temperature T [K], inlet
and bleed valve openings x_in, x_bl [-], muscle length l [m], its rate v [m/s], braid friction
force z [N], and the output of the play on the pressure z_p (gauge) [Pa] that the force law sees
(equal to the gauge pressure without a play).

Components (``docs/plant.md`` gives the parameters and why):

- supply: a regulated reservoir at ``supply_pressure`` with optional droop at high flow;
- valves: ISO 6358 flow through a sonic conductance C·x with critical pressure ratio b (choked
  below b, elliptic subsonic branch above, linearised in the last 0.1 % before equal pressures so
  the flow stays Lipschitz); opening x follows the coil current with a first-order lag; the coil
  current is the Arduino's PWM duty through the LM358 driver; below the dead band the valve stays
  shut;
- chamber: ideal gas with *pressure* as the state (no ``pow`` in the right-hand side). Energy
  balance with wall heat exchange (Richer & Hurmuzlu 2000, eq. 9–10; inflow at the supply
  temperature, outflow at the chamber's):

      ṗ = (γ/V)·(R·Σ ṁ_k·T_k − p·V̇) + ((γ − 1)/V)·h·A·(T_w − T)
      Ṫ = (T/(p·V))·(V·ṗ + p·V̇ − R·T·ṁ)

  h·A = 0 is the adiabatic chamber, h·A → ∞ the isothermal one. The *polytropic* option (the
  previous model, kept for comparison) is the same equations with γ → n, every T_k = T and
  h·A = 0, which is exactly p/ρⁿ = const;
- volume: tubing dead volume plus the tube lumen of the braid's diameter at the actual braid
  angle (eq. 2 gives θ from l); optional leak;
- muscle force: a registered law of :mod:`mckibben.models.laws` (the static models' own kernel),
  evaluated at the output of a play of threshold ``play_threshold`` on the gauge pressure (a
  direction-aware law's ``"play"`` form, :mod:`mckibben.models.hysteresis.direction`; threshold 0:
  at the pressure itself), never pushing; passive tube stiffness beyond the rest length; braid
  friction as a Dahl element;
  *end stops*: the length stays between the braid's locking length (cos θ = 1/√3) and its
  straight length (cos θ = 1), where the load rests on the braid instead of stretching it;
- load: hanging mass over the pulley (gravity, damping), a blocked end, or a spring.

References
----------
ISO 6358-1:2013; Richer, E., Hurmuzlu, Y. (2000), A high performance pneumatic force actuator
system, ASME J. Dyn. Syst. Meas. Control 122(3), 416–425; Tondu & Lopez (2000); Chou &
Hannaford (1996); [mpam-characterization] eq. (2)–(3), §III–IV; Dahl, P. R. (1968).
"""

from __future__ import annotations

import math


from mckibben._jit import generated_module, kernel
from mckibben.models import laws as LW
from mckibben.plant import params as P
from mckibben.plant import packing as PK
from mckibben.models.laws import NTH
from mckibben.plant.packing import NP, P_ATM, R_AIR, RHO0, T0  # module globals the kernels fold

W = 64  #: lanes per block (instances innermost; 32–64 vectorize, 8 did not; 64 measured 6 % faster than 32)
NS = 8
S_P, S_T, S_XIN, S_XBL, S_LEN, S_VEL, S_FRIC, S_PLAY = range(NS)
# stages of the block's state area: the state, the four RK4 slopes, the stage state
ST_S, ST_K1, ST_K2, ST_K3, ST_K4, ST_TMP = range(6)
NST = 6
# rows of the scratch area
SC_PG, SC_LE, SC_FL, SC_LOLD, SC_XIN, SC_XBL, SC_FORCE, SC_MASS = range(8)
NSC = 8
#: Offsets of the areas of a block array (in float64 elements).
OFF_P = 0
OFF_TH = OFF_P + NP * W
OFF_ST = OFF_TH + NTH * W
OFF_SC = OFF_ST + NST * NS * W
BLOCK = OFF_SC + NSC * W  #: length of a block array

LAMINAR = 0.999  # pressure ratio above which the subsonic flow is linearised to zero


def _row(col) -> int:
    return OFF_P + int(col) * W


# parameter rows (IntEnum members as plain int offsets: Numba folds module-level ints)
_C = PK.Col
X_SUPPLY = _row(_C.supply_pressure)
X_DROOP = _row(_C.supply_droop)
X_CIN = _row(_C.valve_conductance)
X_CBL = _row(_C.bleed_conductance)
X_B = _row(_C.critical_ratio)
X_DB = _row(_C.dead_band)
X_DRV = _row(_C.driver_gain)
X_VDEAD = _row(_C.dead_volume)
X_CLEAK = _row(_C.leak_conductance)
X_TS = _row(_C.temperature)
X_L0 = _row(_C.nominal_length)
X_KP = _row(_C.passive_stiffness)
X_F0 = _row(_C.friction_force)
X_F1 = _row(_C.friction_per_pa)
X_SIG = _row(_C.friction_stiffness)
X_PLAY = _row(_C.play_threshold)
X_LF = _row(_C.load_force)
X_DAMP = _row(_C.damping)
X_LFREE = _row(_C.spring_free_length)
X_K2 = _row(_C.k2)
X_INV_K1LS = _row(_C.inv_k1ls)
X_OD_SIN0 = _row(_C.od_sin0)
X_WALLD = _row(_C.wall_step)
X_DMIN = _row(_C.d_min)
X_INVTAU = _row(_C.inv_valve_tau)
X_LMIN = _row(_C.l_min)
X_LMAX = _row(_C.l_max)
X_MOB = _row(_C.mobile)
X_INVM = _row(_C.inv_mass)
X_KS = _row(_C.spring_rate)
X_KGAS = _row(_C.k_gas)
X_INFLOW_T = _row(_C.inflow_at_supply)
X_HA = _row(_C.h_area)
X_INV1MB = _row(_C.inv_1mb)
X_PHILAM = _row(_C.phi_laminar)
X_GSUP = _row(_C.g_supply)


def st_row(stage: int, r: int) -> int:
    """Offset of state row r of a stage in a block array."""
    return OFF_ST + (stage * NS + r) * W


def sc_row(r: int) -> int:
    """Offset of scratch row r in a block array."""
    return OFF_SC + r * W


Y_PG, Y_LE, Y_FL, Y_LOLD, Y_XIN, Y_XBL, Y_FORCE, Y_MASS = (sc_row(r) for r in range(NSC))
Z_P, Z_T, Z_XIN, Z_XBL, Z_LEN, Z_VEL, Z_FRIC, Z_PLAY = (st_row(ST_S, r) for r in range(NS))

def _dispatch_source() -> str:
    """The source of the law dispatchers: one branch per registered law (:data:`~mckibben.models.laws.LAW_NAMES`).

    ``law_force(law, n, bk)``: the law of index ``law`` for lanes 0..n-1, reading gauge pressure
    [Pa] and length [m] from the block's scratch rows, θ from its ``OFF_TH`` area, writing the force
    [N] into its force row. ``law_value(law, pressure, length, th, o, w)``: the same kernel at one
    point [N] (the static start's bisection). An index outside the registry gives NaN, which the
    plant's checks refuse. Each kernel is a true global of the generated module (a cached function
    never takes a compiled function as an argument, :mod:`mckibben._jit`).
    """
    imports, force, value = [], [], []
    for i, name in enumerate(LW.LAW_NAMES):
        kern = LW.LAWS[name].kernel
        imports.append(f"from {kern.__module__} import {kern.__name__} as law_{i}  # {name}")
        force += [f"    {'if' if i == 0 else 'elif'} law == {i}:", "        for j in range(n):",
                  f"            bk[Y_FL + j] = law_{i}(bk[Y_PG + j], bk[Y_LE + j], bk, OFF_TH + j, W)"]
        value += [f"    if law == {i}:", f"        return law_{i}(pressure, length, th, o, w)"]
    return "\n".join([
        "# Generated by mckibben.plant.physics from the law registry (mckibben.models.laws). Do not edit.",
        "import math", "", "from mckibben._jit import kernel  # kernel-decorator", *imports, "",
        f"Y_PG, Y_LE, Y_FL, OFF_TH, W = {Y_PG}, {Y_LE}, {Y_FL}, {OFF_TH}, {W}", "", "",
        '@kernel(error_model="numpy")', "def law_force(law, n, bk):", *force, "    else:",
        "        for j in range(n):", "            bk[Y_FL + j] = math.nan", "", "",
        '@kernel(error_model="numpy", inline="always")', "def law_value(law, pressure, length, th, o, w):", *value,
        "    return math.nan", ""])


#: The index of the default law (the plant's ``calibrated`` force model), which :func:`rhs` runs
#: inline (its loop vectorizes with the rest).
_TL = LW.LAW_INDEX[PK.FORCE_MODELS[P.PlantParams.force_model]]
#: The law dispatchers, generated from the registry and cached per user (:func:`mckibben._jit.generated_module`).
_DISPATCH = generated_module("law_dispatch", _dispatch_source())
law_force = _DISPATCH.law_force
law_value = _DISPATCH.law_value


@kernel(error_model="numpy", inline="always")
def flow_function(r, b, inv_1mb, phi_lam):
    """ISO 6358 flow function φ of the pressure ratio r = p_down/p_up ≤ 1. [-]

    1 when choked (r ≤ b), the ellipse √(1 − ((r − b)/(1 − b))²) above, and a straight line to 0
    over the last 0.1 % (r ≥ 0.999, slope ``phi_lam`` = φ(0.999)/0.001) so the flow is Lipschitz.
    ``inv_1mb`` = 1/(1 − b).
    """
    s = (r - b) * inv_1mb
    phi = math.sqrt(1.0 - s * s) if r < LAMINAR else phi_lam * (1.0 - r)
    return 1.0 if r <= b else phi


@kernel(error_model="numpy")
def iso6358_flow(c, p1, t1, p2, t2, b):
    """Signed mass flow from p1 to p2 through sonic conductance c (ISO 6358). [kg/s]

    Parameters: c [m³/(s·Pa)], p1, p2 absolute [Pa], t1, t2 their temperatures [K] (the upstream
    one counts), b [-]. (The integrator computes the same with its per-instance constants.)
    """
    rev = p2 > p1
    hi = p2 if rev else p1
    lo = p1 if rev else p2
    tu = t2 if rev else t1
    sl = (LAMINAR - b) / (1.0 - b)
    q = c * RHO0 * hi * math.sqrt(T0 / tu) * flow_function(lo / hi, b, 1.0 / (1.0 - b),
                                                            math.sqrt(1.0 - sl * sl) / (1.0 - LAMINAR))
    return -q if rev else q


@kernel(error_model="numpy")
def valve_target(pwm, drv, db):
    """Valve opening commanded by a PWM count through the driver and dead band. [-]"""
    current = pwm / 255.0 * drv
    current = 1.0 if current > 1.0 else current
    return (current - db) / (1.0 - db) if current > db else 0.0


@kernel(error_model="numpy", inline="always")
def volume(length, bk, j):
    """Chamber volume and its derivative in length at a length: (V [m³], dV/dl [m²])."""
    ik = bk[X_INV_K1LS + j]
    c = (length - bk[X_K2 + j]) * ik
    free = c > 0.05 and c < 0.9999
    c = 0.05 if c < 0.05 else (0.9999 if c > 0.9999 else c)
    sn = math.sqrt(1.0 - c * c)
    ods = bk[X_OD_SIN0 + j]
    d = ods * sn - bk[X_WALLD + j]
    dd = -ods * c / sn * ik if free else 0.0
    dmin = bk[X_DMIN + j]
    low = d < dmin
    d = dmin if low else d
    dd = 0.0 if low else dd
    return (bk[X_VDEAD + j] + 0.25 * math.pi * d * d * length,
            0.25 * math.pi * (2.0 * d * dd * length + d * d))


@kernel(error_model="numpy", inline="always")
def play_step(z, pressure, r):
    """The play operator at one sample: its output after ``pressure`` from the output ``z`` before. [Pa]

    z ← min(max(z, P − r), P + r), the operator of :mod:`mckibben.models.hysteresis.direction`
    (:func:`~mckibben.models.hysteresis.direction.play_pressure`, whose ``play_matrix`` runs it over
    a sequence in NumPy) in the compiled kernels' scalar form; ``tests/test_plant_play.py`` holds
    the two equal on a pressure history. Written as two selects so a NaN pressure stays NaN, and
    r = 0 gives P exactly (bit for bit: no play). z, P gauge [Pa], r ≥ 0 [Pa].
    """
    lo = pressure - r
    hi = pressure + r
    y = z if z > lo else lo
    return y if y < hi else hi


@kernel(error_model="numpy", inline="always")
def clamp_length(n, bk, k):
    """The pressure and the length the force law sees, of stage k, per lane.

    The length inside the end stops; the pressure the play's output on stage k's gauge pressure
    from the play's state (:func:`play_step`; the gauge pressure itself without a play).
    """
    zp = OFF_ST + (k * NS + S_P) * W
    zl = OFF_ST + (k * NS + S_LEN) * W
    zz = OFF_ST + (k * NS + S_PLAY) * W
    for j in range(n):
        x = bk[zl + j]
        lo = bk[X_LMIN + j]
        hi = bk[X_LMAX + j]
        bk[Y_LE + j] = lo if x < lo else (hi if x > hi else x)
        bk[Y_PG + j] = play_step(bk[zz + j], bk[zp + j] - P_ATM, bk[X_PLAY + j])


@kernel(error_model="numpy", inline="always")
def muscle_force(fl, length, bk, j):
    """Pulling force from the law's value ``fl``: never pushing, plus the tube beyond its rest length. [N]"""
    stretch = length - bk[X_L0 + j]
    return (fl if fl > 0.0 else 0.0) + bk[X_KP + j] * (stretch if stretch > 0.0 else 0.0)


# Not inlined. rk4_step passes the stage numbers k, dk as constants, so Numba compiles one copy per
# stage (four): with the row offsets known, LLVM proves the stage's reads and writes apart and
# vectorizes the lane loop. Passed typed (np.int64), one copy served all four and the integrator ran
# 3.7x slower (benchmarks/RESULTS.md, issue #34); tests/test_compile_cache.py holds the four.
@kernel(error_model="numpy", fastmath={"contract"})
def rhs(n, bk, k, dk, law):
    """Time derivatives of stage ``k``'s states into stage ``dk`` (friction and play rows held: see :func:`rk4_step`).

    Valve targets come from scratch rows ``SC_XIN``, ``SC_XBL``.
    """
    clamp_length(n, bk, k)
    if law == _TL:  # the default law inline (its loop vectorizes with the rest, no call)
        for j in range(n):
            bk[Y_FL + j] = LW.tondu_lopez(bk[Y_PG + j], bk[Y_LE + j], bk, OFF_TH + j, W)
    else:
        law_force(law, n, bk)
    a = OFF_ST + k * NS * W
    o = OFF_ST + dk * NS * W
    for j in range(n):
        p = bk[a + S_P * W + j]
        t = bk[a + S_T * W + j]
        xin = bk[a + S_XIN * W + j]
        xbl = bk[a + S_XBL * W + j]
        length = bk[a + S_LEN * W + j]
        v = bk[a + S_VEL * W + j]
        mob = bk[X_MOB + j]
        vol, dvdl = volume(bk[Y_LE + j], bk, j)
        vdot = dvdl * v * mob
        ts = bk[X_TS + j]
        b = bk[X_B + j]
        i1mb = bk[X_INV1MB + j]
        plam = bk[X_PHILAM + j]
        xo = xin if xin > 0.0 else 0.0
        xb = xbl if xbl > 0.0 else 0.0
        gt = math.sqrt(T0 / t)  # ISO 6358's √(T0/T_up) for air leaving the chamber
        # inlet: supply ↔ chamber (air from the supply at its temperature, back-flow at the chamber's)
        psup = P_ATM + bk[X_SUPPLY + j] * (1.0 - bk[X_DROOP + j] * xo)
        fwd = psup >= p
        hi = psup if fwd else p
        lo = p if fwd else psup
        q = bk[X_CIN + j] * xo * RHO0 * hi * (bk[X_GSUP + j] if fwd else gt) * flow_function(lo / hi, b, i1mb, plam)
        m_in = q if fwd else -q
        # bleed and leak: chamber ↔ atmosphere, one pressure ratio for both
        out = p >= P_ATM
        hi = p if out else P_ATM
        lo = P_ATM if out else p
        q = (bk[X_CBL + j] * xb + bk[X_CLEAK + j]) * RHO0 * hi * (gt if out else bk[X_GSUP + j]) * flow_function(
            lo / hi, b, i1mb, plam)
        m_out = -q if out else q
        mdot = m_in + m_out
        inflow = (m_in if m_in > 0.0 else 0.0) + (m_out if m_out > 0.0 else 0.0)
        enth = t * mdot + bk[X_INFLOW_T + j] * (ts - t) * inflow  # Σ ṁ_k·T_k
        kg = bk[X_KGAS + j]
        iv = 1.0 / vol
        dp = kg * iv * (R_AIR * enth - p * vdot) + (kg - 1.0) * iv * bk[X_HA + j] * (ts - t)
        bk[o + S_P * W + j] = dp
        ip = 1.0 / p
        bk[o + S_T * W + j] = t * (dp * ip + iv * vdot - iv * R_AIR * t * mdot * ip)
        inv_tau = bk[X_INVTAU + j]
        bk[o + S_XIN * W + j] = (bk[Y_XIN + j] - xin) * inv_tau
        bk[o + S_XBL * W + j] = (bk[Y_XBL + j] - xbl) * inv_tau
        fm = muscle_force(bk[Y_FL + j], length, bk, j)
        f_ext = bk[X_LF + j] - bk[X_KS + j] * (length - bk[X_LFREE + j])
        acc = (f_ext - fm - bk[a + S_FRIC * W + j] - bk[X_DAMP + j] * v) * bk[X_INVM + j]
        bk[o + S_LEN * W + j] = mob * v
        bk[o + S_VEL * W + j] = mob * acc
        bk[o + S_FRIC * W + j] = 0.0
        bk[o + S_PLAY * W + j] = 0.0


#: Blocks of more lanes than this run the RK4 stage and update loops over all W lanes (see :func:`_stage`).
NARROW = 8


@kernel(error_model="numpy", inline="always")
def _axpy_rows(bk, dst, src, d, h, n):
    """Rows ``dst`` ← rows ``src`` + h·rows ``d``, for every state row, lanes 0..n−1 (or all W).

    A block of more than :data:`NARROW` lanes runs over all W lanes: the trip count is then a
    compile-time constant and LLVM vectorizes the loop whole (with the block's n as the trip count it
    did not, and this loop cost 15 ns per lane-substep, more than the right-hand side;
    ``docs/plant.md``). Lanes past n are never read: a block array is new and zeroed for each
    call, and the right-hand side writes lanes below n only, so their slopes stay zero.
    A narrow block (one rig) keeps the per-lane loop: 64 lanes would be 8-64 times its work.
    """
    if n > NARROW:
        for q in range(NS * W):
            bk[dst + q] = bk[src + q] + h * bk[d + q]
    else:
        for r in range(NS):
            for j in range(n):
                bk[dst + r * W + j] = bk[src + r * W + j] + h * bk[d + r * W + j]


@kernel(error_model="numpy", inline="always")
def _stage(n, bk, h, dk):
    """The stage state: state + h·(slope ``dk``)."""
    _axpy_rows(bk, OFF_ST + ST_TMP * NS * W, OFF_ST + ST_S * NS * W, OFF_ST + dk * NS * W, h, n)


@kernel(error_model="numpy", inline="always")
def _after_step(bk, j, dt):
    """End stops, the Dahl friction and the play's update of lane j after a step (see :func:`rk4_step`)."""
    x = bk[Z_LEN + j]
    v = bk[Z_VEL + j]
    lo = bk[X_LMIN + j]
    hi = bk[X_LMAX + j]
    over = x > hi
    under = x < lo
    x = hi if over else (lo if under else x)
    bk[Z_LEN + j] = x
    v = (v if v < 0.0 else 0.0) if over else v
    v = (v if v > 0.0 else 0.0) if under else v
    bk[Z_VEL + j] = v
    vbar = (x - bk[Y_LOLD + j]) / dt
    pg = bk[Z_P + j] - P_ATM
    fc = bk[X_F0 + j] + bk[X_F1 + j] * (pg if pg > 0.0 else 0.0)
    sv = bk[X_SIG + j] * dt
    den = fc + sv * abs(vbar)
    z = fc * (bk[Z_FRIC + j] + sv * vbar) / den if den > 0.0 else 0.0
    bk[Z_FRIC + j] = z * bk[X_MOB + j]
    bk[Z_PLAY + j] = play_step(bk[Z_PLAY + j], pg, bk[X_PLAY + j])


@kernel(error_model="numpy", fastmath={"contract"})
def rk4_step(n, bk, law, dt):
    """One step of size dt for every lane of the block array ``bk``, in place: classical
    Runge–Kutta, then the end stops and the friction.

    The Dahl element ż = σ(v − |v|·z/F_c) is stiff when F_c is small and the end moves fast; it is
    split off: the Runge–Kutta stages hold z, then z takes one backward-Euler step with the step's
    mean velocity v̄ = Δl/dt, z ← F_c·(z + σ·v̄·dt)/(F_c + σ·|v̄|·dt): stable at any step, exact in
    both limits (v̄ = 0 keeps z, large σ|v̄|dt/F_c gives F_c·sgn v̄), and F_c = 0 gives z = 0 (no
    friction). Its local error against the exact exponential solution is (σ|v̄|dt/F_c)²/2 of
    the gap z − F_c·sgn v̄ (backward Euler's), and it needs no ``exp``, so the loop vectorizes.
    The end stops project the length back inside [l_min, l_max] and stop any motion outward.

    The play on the pressure (threshold r, ``play_threshold``; its output z_p the law's pressure)
    is split off the same way: its row is held through the stages, each stage's law sees
    clamp(z_p, P_stage − r, P_stage + r) (:func:`play_step` from the step's starting state), and
    after the step z_p ← clamp(z_p, P − r, P + r) at the step's end pressure. Why: the operator is
    rate independent and not differentiable (its output has no time derivative of its own, only
    a switch between following the pressure and holding), so it has no place among the
    Runge–Kutta slopes; the update at the step's end is the operator sampled at every step,
    exactly (the library's :func:`~mckibben.models.hysteresis.direction.play_pressure` over the
    step pressures gives the same z_p), and each stage sees the play's output as it would be at
    that stage's pressure, so the law's force stays continuous within the step. A pressure that
    reverses inside one step (0.1 ms) and returns is missed, as by any sampled operator. r = 0
    gives z_p = P bit for bit: the plant without a play.
    """
    rhs(n, bk, ST_S, ST_K1, law)
    _stage(n, bk, 0.5 * dt, ST_K1)
    rhs(n, bk, ST_TMP, ST_K2, law)
    _stage(n, bk, 0.5 * dt, ST_K2)
    rhs(n, bk, ST_TMP, ST_K3, law)
    _stage(n, bk, dt, ST_K3)
    rhs(n, bk, ST_TMP, ST_K4, law)
    h6 = dt / 6.0
    k1 = OFF_ST + ST_K1 * NS * W
    k2 = OFF_ST + ST_K2 * NS * W
    k3 = OFF_ST + ST_K3 * NS * W
    k4 = OFF_ST + ST_K4 * NS * W
    # the slopes' weighted sum into stage 1's area (k1 is not needed after it), then one update
    if n > NARROW:
        for q in range(NS * W):
            bk[k1 + q] = bk[k1 + q] + 2.0 * bk[k2 + q] + 2.0 * bk[k3 + q] + bk[k4 + q]
        for j in range(W):
            bk[Y_LOLD + j] = bk[Z_LEN + j]
    else:
        for r in range(NS):
            for j in range(n):
                q = r * W + j
                bk[k1 + q] = bk[k1 + q] + 2.0 * bk[k2 + q] + 2.0 * bk[k3 + q] + bk[k4 + q]
        for j in range(n):
            bk[Y_LOLD + j] = bk[Z_LEN + j]
    _axpy_rows(bk, Z_P, Z_P, k1, h6, n)
    if n > NARROW:
        for j in range(W):
            _after_step(bk, j, dt)
    else:
        for j in range(n):
            _after_step(bk, j, dt)


@kernel(error_model="numpy")
def advance(n, bk, law, dt, substeps):
    """``substeps`` RK4 steps of dt for every lane (valve targets held in the scratch rows)."""
    for _ in range(substeps):
        rk4_step(n, bk, law, dt)


@kernel(error_model="numpy")
def outputs(n, bk, law):
    """Muscle force [N] and air mass [kg] of the lanes now, into scratch rows ``SC_FORCE``, ``SC_MASS``."""
    clamp_length(n, bk, ST_S)
    law_force(law, n, bk)
    for j in range(n):
        bk[Y_FORCE + j] = muscle_force(bk[Y_FL + j], bk[Z_LEN + j], bk, j)
        vol, _ = volume(bk[Y_LE + j], bk, j)
        bk[Y_MASS + j] = bk[Z_P + j] * vol / (R_AIR * bk[Z_T + j])


@kernel(error_model="numpy")
def load_block(b0, nl, prm, theta, s0, bk):
    """Copy instances b0..b0+nl-1 (rows of ``prm`` (N, NP), columns of ``theta`` (NTH, N), rows of
    ``s0`` (N, NS)) into the block array ``bk``."""
    for c in range(prm.shape[1]):
        for j in range(nl):
            bk[OFF_P + c * W + j] = prm[b0 + j, c]
    for r in range(theta.shape[0]):
        for j in range(nl):
            bk[OFF_TH + r * W + j] = theta[r, b0 + j]
    for r in range(NS):
        for j in range(nl):
            bk[Z_P + r * W + j] = s0[b0 + j, r]
