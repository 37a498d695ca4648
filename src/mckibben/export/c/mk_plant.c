/*
 * mk_plant.c: the plant's physics in C99, a line-by-line port of mckibben.plant.physics (the
 * right-hand side, the RK4 step with the end stops, the Dahl friction and the play on the pressure), of
 * mckibben.plant.packing.derive_columns and of the static start (mckibben.plant.simulator.static_equilibrium);
 * the force laws' C faces are in the generated mk_laws.c (mckibben.plant.c_layout.laws_c, from each
 * law's models/laws/<law>.c). The Python/Numba plant is the source of truth; tests/test_export_fmu.py holds this port equal to it. Keep the order of the arithmetic
 * the same as the Python's when editing either side.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "mk_plant.h"

#define PR(c) (p->prm[MK_C_##c])

/* ---- parameters ---------------------------------------------------------------------------- */

void mk_defaults(mk_plant *p)
{
    int j;
    memset(p, 0, sizeof *p);
    for (j = 0; j < MK_NF; j++)
        p->prm[j] = MK_FIELDS[j];
    for (j = 0; j < MK_NTH; j++)
        p->th[j] = MK_THETA[j];
    p->law = MK_LAW;
    mk_derive(p);
}

static double clip(double x, double lo, double hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}

void mk_derive(mk_plant *p)
{
    double k1ls = PR(k1) * PR(strand_length);
    double c0, area, b, sl;
    int kind = (int)PR(load_kind);
    PR(inv_k1ls) = 1.0 / k1ls;
    c0 = clip((PR(nominal_length) - PR(k2)) / k1ls, 0.05, 0.9999);
    PR(od_sin0) = PR(outer_diameter) / sqrt(1.0 - c0 * c0);
    PR(wall_step) = PR(outer_diameter) - PR(inner_diameter);
    PR(d_min) = 0.1 * PR(inner_diameter);
    PR(inv_valve_tau) = 1.0 / PR(valve_tau);
    PR(l_min) = k1ls / sqrt(3.0) + PR(k2);
    PR(l_max) = k1ls + PR(k2);
    PR(mobile) = kind == MK_LOAD_BLOCKED ? 0.0 : 1.0;
    PR(inv_mass) = 1.0 / (PR(moving_mass) + (kind == MK_LOAD_HANGING ? PR(load_force) / MK_G : 0.0));
    PR(spring_rate) = kind == MK_LOAD_SPRING ? PR(spring_stiffness) : 0.0;
    PR(k_gas) = MK_THERMAL_ENERGY ? MK_GAMMA : PR(polytropic_n);
    PR(inflow_at_supply) = MK_THERMAL_ENERGY ? 1.0 : 0.0;
    area = 4.0 * PR(dead_volume) / PR(tube_diameter) + MK_PI * PR(inner_diameter) * PR(nominal_length);
    PR(h_area) = MK_THERMAL_ENERGY ? PR(heat_transfer_coefficient) * area : 0.0;
    b = PR(critical_ratio);
    PR(inv_1mb) = 1.0 / (1.0 - b);
    sl = (MK_LAMINAR - b) / (1.0 - b);
    PR(phi_laminar) = sqrt(1.0 - sl * sl) / (1.0 - MK_LAMINAR);
    PR(g_supply) = sqrt(MK_T0 / PR(temperature));
}

int mk_check(const mk_plant *p, char *msg, int size)
{
    double s = PR(supply_pressure), f = PR(load_force);
    if (!(s > 0.0 && s <= MK_P_MAX_LIMIT)) {
        snprintf(msg, (size_t)size, "supply_pressure = %g Pa: must be above 0 and at most %g Pa (gauge)", s,
                 MK_P_MAX_LIMIT);
        return 1;
    }
    if (!(f >= 0.0 && isfinite(f))) {
        snprintf(msg, (size_t)size, "load_force = %g N: a hanging weight must be a finite number >= 0", f);
        return 1;
    }
    return 0;
}

/* ---- the chamber, the valves, the muscle ---------------------------------------------------- */

static double flow_function(double r, double b, double inv_1mb, double phi_lam)
{
    double s = (r - b) * inv_1mb;
    double phi = r < MK_LAMINAR ? sqrt(1.0 - s * s) : phi_lam * (1.0 - r);
    return r <= b ? 1.0 : phi;
}

double mk_valve_target(double pwm, double drv, double db)
{
    double current = pwm / 255.0 * drv;
    current = current > 1.0 ? 1.0 : current;
    return current > db ? (current - db) / (1.0 - db) : 0.0;
}

static void volume(const mk_plant *p, double length, double *vol, double *dvdl)
{
    double ik = PR(inv_k1ls);
    double c = (length - PR(k2)) * ik;
    int free_ = c > 0.05 && c < 0.9999;
    double sn, ods, d, dd, dmin;
    int low;
    c = c < 0.05 ? 0.05 : (c > 0.9999 ? 0.9999 : c);
    sn = sqrt(1.0 - c * c);
    ods = PR(od_sin0);
    d = ods * sn - PR(wall_step);
    dd = free_ ? -ods * c / sn * ik : 0.0;
    dmin = PR(d_min);
    low = d < dmin;
    d = low ? dmin : d;
    dd = low ? 0.0 : dd;
    *vol = PR(dead_volume) + 0.25 * MK_PI * d * d * length;
    *dvdl = 0.25 * MK_PI * (2.0 * d * dd * length + d * d);
}

static double muscle_force(const mk_plant *p, double fl, double length)
{
    double stretch = length - PR(nominal_length);
    return (fl > 0.0 ? fl : 0.0) + PR(passive_stiffness) * (stretch > 0.0 ? stretch : 0.0);
}

/* The play operator at one sample (mckibben.plant.physics.play_step): its output after pressure from z. */
static double play_step(double z, double pressure, double r)
{
    double lo = pressure - r, hi = pressure + r;
    double y = z > lo ? z : lo;
    return y < hi ? y : hi;
}

static double clamped_length(const mk_plant *p, double x)
{
    double lo = PR(l_min), hi = PR(l_max);
    return x < lo ? lo : (x > hi ? hi : x);
}

/* Time derivatives of state y into dy (the friction and play rows held: see rk4_step). */
static void rhs(const mk_plant *p, const double *y, double *dy)
{
    double le = clamped_length(p, y[MK_S_LEN]);
    double pg = play_step(y[MK_S_PLAY], y[MK_S_P] - MK_P_ATM, PR(play_threshold));
    double fl = mk_law(p->law, pg, le, p->th);
    double pa = y[MK_S_P], t = y[MK_S_T], xin = y[MK_S_XIN], xbl = y[MK_S_XBL];
    double length = y[MK_S_LEN], v = y[MK_S_VEL];
    double mob = PR(mobile);
    double vol, dvdl, vdot, ts, b, i1mb, plam, xo, xb, gt, psup, hi, lo, q, m_in, m_out, mdot, inflow, enth;
    double kg, iv, dp, ip, inv_tau, fm, f_ext, acc;
    int fwd, out;
    volume(p, le, &vol, &dvdl);
    vdot = dvdl * v * mob;
    ts = PR(temperature);
    b = PR(critical_ratio);
    i1mb = PR(inv_1mb);
    plam = PR(phi_laminar);
    xo = xin > 0.0 ? xin : 0.0;
    xb = xbl > 0.0 ? xbl : 0.0;
    gt = sqrt(MK_T0 / t);
    /* inlet: supply <-> chamber */
    psup = MK_P_ATM + PR(supply_pressure) * (1.0 - PR(supply_droop) * xo);
    fwd = psup >= pa;
    hi = fwd ? psup : pa;
    lo = fwd ? pa : psup;
    q = PR(valve_conductance) * xo * MK_RHO0 * hi * (fwd ? PR(g_supply) : gt) * flow_function(lo / hi, b, i1mb, plam);
    m_in = fwd ? q : -q;
    /* bleed and leak: chamber <-> atmosphere */
    out = pa >= MK_P_ATM;
    hi = out ? pa : MK_P_ATM;
    lo = out ? MK_P_ATM : pa;
    q = (PR(bleed_conductance) * xb + PR(leak_conductance)) * MK_RHO0 * hi * (out ? gt : PR(g_supply))
        * flow_function(lo / hi, b, i1mb, plam);
    m_out = out ? -q : q;
    mdot = m_in + m_out;
    inflow = (m_in > 0.0 ? m_in : 0.0) + (m_out > 0.0 ? m_out : 0.0);
    enth = t * mdot + PR(inflow_at_supply) * (ts - t) * inflow;
    kg = PR(k_gas);
    iv = 1.0 / vol;
    dp = kg * iv * (MK_R_AIR * enth - pa * vdot) + (kg - 1.0) * iv * PR(h_area) * (ts - t);
    dy[MK_S_P] = dp;
    ip = 1.0 / pa;
    dy[MK_S_T] = t * (dp * ip + iv * vdot - iv * MK_R_AIR * t * mdot * ip);
    inv_tau = PR(inv_valve_tau);
    dy[MK_S_XIN] = (p->x_in_target - xin) * inv_tau;
    dy[MK_S_XBL] = (p->x_bl_target - xbl) * inv_tau;
    fm = muscle_force(p, fl, length);
    f_ext = PR(load_force) - PR(spring_rate) * (length - PR(spring_free_length));
    acc = (f_ext - fm - y[MK_S_FRIC] - PR(damping) * v) * PR(inv_mass);
    dy[MK_S_LEN] = mob * v;
    dy[MK_S_VEL] = mob * acc;
    dy[MK_S_FRIC] = 0.0;
    dy[MK_S_PLAY] = 0.0;
}

/* End stops, the Dahl friction and the play's update after a step (mckibben.plant.physics._after_step). */
static void after_step(mk_plant *p, double l_old, double dt)
{
    double x = p->s[MK_S_LEN], v = p->s[MK_S_VEL];
    double lo = PR(l_min), hi = PR(l_max);
    int over = x > hi, under = x < lo;
    double vbar, pg, fc, sv, den, z;
    x = over ? hi : (under ? lo : x);
    p->s[MK_S_LEN] = x;
    v = over ? (v < 0.0 ? v : 0.0) : v;
    v = under ? (v > 0.0 ? v : 0.0) : v;
    p->s[MK_S_VEL] = v;
    vbar = (x - l_old) / dt;
    pg = p->s[MK_S_P] - MK_P_ATM;
    fc = PR(friction_force) + PR(friction_per_pa) * (pg > 0.0 ? pg : 0.0);
    sv = PR(friction_stiffness) * dt;
    den = fc + sv * fabs(vbar);
    z = den > 0.0 ? fc * (p->s[MK_S_FRIC] + sv * vbar) / den : 0.0;
    p->s[MK_S_FRIC] = z * PR(mobile);
    p->s[MK_S_PLAY] = play_step(p->s[MK_S_PLAY], pg, PR(play_threshold));
}

/* One classical Runge-Kutta step of dt, then the end stops and the friction (rk4_step). */
static void rk4_step(mk_plant *p, double dt)
{
    double k1[MK_NS], k2[MK_NS], k3[MK_NS], k4[MK_NS], y[MK_NS];
    double h6 = dt / 6.0, l_old;
    int r;
    rhs(p, p->s, k1);
    for (r = 0; r < MK_NS; r++) y[r] = p->s[r] + 0.5 * dt * k1[r];
    rhs(p, y, k2);
    for (r = 0; r < MK_NS; r++) y[r] = p->s[r] + 0.5 * dt * k2[r];
    rhs(p, y, k3);
    for (r = 0; r < MK_NS; r++) y[r] = p->s[r] + dt * k3[r];
    rhs(p, y, k4);
    for (r = 0; r < MK_NS; r++) k1[r] = k1[r] + 2.0 * k2[r] + 2.0 * k3[r] + k4[r];
    l_old = p->s[MK_S_LEN];
    for (r = 0; r < MK_NS; r++) p->s[r] = p->s[r] + h6 * k1[r];
    after_step(p, l_old, dt);
}

void mk_set_commands(mk_plant *p, int inlet, int bleed)
{
    p->inlet = inlet;
    p->bleed = bleed;
    p->x_in_target = mk_valve_target((double)inlet, PR(driver_gain), PR(dead_band));
    p->x_bl_target = mk_valve_target((double)bleed, PR(driver_gain), PR(dead_band));
}

int mk_advance(mk_plant *p, double h)
{
    double dt = MK_TS / MK_SUBSTEPS;
    double n = floor(h / dt + 0.5);
    long k, steps;
    if (!(n >= 1.0) || fabs(n * dt - h) > 1e-9 * h) {
        n = ceil(h / dt);
        dt = h / n;
    }
    steps = (long)n;
    for (k = 0; k < steps; k++)
        rk4_step(p, dt);
    p->time += h;
    if (!(isfinite(p->s[MK_S_P]) && isfinite(p->s[MK_S_T]) && isfinite(p->s[MK_S_LEN]) && p->s[MK_S_P] > 0.0
          && p->s[MK_S_T] > 0.0))
        return 1;
    return 0;
}

void mk_outputs(const mk_plant *p, double *pressure, double *length, double *force)
{
    double le = clamped_length(p, p->s[MK_S_LEN]);
    double pg = p->s[MK_S_P] - MK_P_ATM;
    *pressure = pg;
    *length = p->s[MK_S_LEN];
    *force = muscle_force(p, mk_law(p->law, play_step(p->s[MK_S_PLAY], pg, PR(play_threshold)), le, p->th),
                          p->s[MK_S_LEN]);
}

/* ---- the static start (mckibben.plant.simulator._balance, _bracket_balance) ------------------- */

static double balance(const mk_plant *p, double pg, double length)
{
    double f = mk_law(p->law, pg, length, p->th);
    double stretch, fm;
    f = f != f ? 0.0 : f;
    stretch = length - PR(nominal_length);
    fm = (f > 0.0 ? f : 0.0) + PR(passive_stiffness) * (stretch > 0.0 ? stretch : 0.0);
    return fm - (PR(load_force) - PR(spring_rate) * (length - PR(spring_free_length)));
}

static double static_length(const mk_plant *p, double pg)
{
    double a = PR(l_min), b = PR(l_max), lo = a, hi = b;
    int status = 0, it, m;
    if (PR(mobile) == 0.0)
        return PR(nominal_length);
    if (balance(p, pg, hi) < 0.0)
        status = 1;
    else if (balance(p, pg, lo) > 0.0)
        status = 2;
    for (it = 0; it < 9; it++) {
        int first = 63;
        double nlo, nhi;
        for (m = 0; m < 64; m++) {
            if (balance(p, pg, lo + (hi - lo) * (m / 63.0)) > 0.0) {
                first = m;
                break;
            }
        }
        first = first > 1 ? first : 1;
        nlo = lo + (hi - lo) * ((first - 1) / 63.0);
        nhi = lo + (hi - lo) * (first / 63.0);
        lo = nlo;
        hi = nhi;
    }
    return status == 1 ? b : (status == 2 ? a : 0.5 * (lo + hi));
}

void mk_initial_state(mk_plant *p)
{
    int r;
    for (r = 0; r < MK_NS; r++) p->s[r] = 0.0;
    p->s[MK_S_P] = MK_P_ATM;
    p->s[MK_S_PLAY] = p->s[MK_S_P] - MK_P_ATM; /* the play's output at rest: the gauge pressure */
    p->s[MK_S_T] = PR(temperature); /* gauge 0: the polytropic T_s·(p/p_atm)^((n-1)/n) is T_s too */
    p->s[MK_S_LEN] = static_length(p, 0.0);
    p->time = 0.0;
    mk_set_commands(p, p->inlet, p->bleed);
}
